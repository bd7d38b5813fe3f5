//! Stage 1 of extraction: cutting a scan into runs of consecutive returns at range jumps,
//! and telling which runs stand in front of their background.

use super::ExtractorConfig;
use crate::scan::{Beam, RangeScan};

/// Consecutive returns of one object: `(beam index, range)` in beam order.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// The returns (beam index, range in m).
    pub points: Vec<(usize, f64)>,
}

impl Run {
    fn first(&self) -> usize {
        self.points.first().map_or(0, |p| p.0)
    }

    fn last(&self) -> usize {
        self.points.last().map_or(0, |p| p.0)
    }
}

/// The jump (m) that separates a return at range `r` from its neighbour.
fn jump(config: &ExtractorConfig, r: f64) -> f64 {
    config.jump_abs + config.jump_rel * r
}

/// Splits `scan` into runs: returns within `config.max_range` whose neighbours differ in
/// range by at most the jump threshold. Anything else (no return, an invalid beam, a
/// return beyond `max_range`, a jump) ends a run.
pub fn runs(scan: &RangeScan<'_>, config: &ExtractorConfig) -> Vec<Run> {
    let mut runs = Vec::new();
    let mut current: Vec<(usize, f64)> = Vec::new();
    for i in 0..scan.len() {
        match scan.beam(i) {
            Beam::Hit(r) if r <= config.max_range => {
                if let Some(&(_, previous)) = current.last()
                    && (r - previous).abs() > jump(config, r.min(previous))
                {
                    runs.push(Run {
                        points: std::mem::take(&mut current),
                    });
                }
                current.push((i, r));
            }
            _ if !current.is_empty() => runs.push(Run {
                points: std::mem::take(&mut current),
            }),
            _ => {}
        }
    }
    if !current.is_empty() {
        runs.push(Run { points: current });
    }
    runs
}

/// True when the beams just outside `run` on both sides saw something farther away (or
/// nothing): the run is a whole object, not one partly hidden behind a closer one or cut
/// by the edge of the scan. An invalid neighbour beam cannot vouch for that either.
pub fn stands_out(scan: &RangeScan<'_>, run: &Run, config: &ExtractorConfig) -> bool {
    let n = scan.len();
    let neighbour = |i: Option<usize>| -> Option<usize> {
        match i {
            Some(i) if i < n => Some(i),
            _ if scan.is_full_turn() => i.map_or(Some(n - 1), |_| Some(0)),
            _ => None,
        }
    };
    let ends = [
        (neighbour(run.first().checked_sub(1)), run.points.first()),
        (neighbour(Some(run.last() + 1)), run.points.last()),
    ];
    ends.into_iter().all(|(beyond, end)| {
        let (Some(beyond), Some(&(_, r_end))) = (beyond, end) else {
            return false;
        };
        match scan.beam(beyond) {
            Beam::NoReturn => true,
            Beam::Hit(r) => r > r_end + jump(config, r_end) || r > config.max_range,
            Beam::Invalid => false,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scan(ranges: &[f32]) -> RangeScan<'_> {
        RangeScan {
            angle_min: 0.0,
            angle_increment: 0.01,
            range_min: 0.1,
            range_max: 30.0,
            ranges,
        }
    }

    #[test]
    fn runs_split_at_jumps_and_gaps() {
        let inf = f32::INFINITY;
        let ranges = [
            5.0,
            5.01,
            5.02,
            8.0,
            8.0,
            inf,
            4.0,
            9.0,
            f32::NAN,
            3.0,
            27.0,
        ];
        let config = ExtractorConfig::default();
        let s = scan(&ranges);
        let runs = runs(&s, &config);
        let indices: Vec<Vec<usize>> = runs
            .iter()
            .map(|r| r.points.iter().map(|p| p.0).collect())
            .collect();
        assert_eq!(
            indices,
            vec![vec![0, 1, 2], vec![3, 4], vec![6], vec![7], vec![9]],
            "27 m is beyond max_range"
        );
        let out: Vec<bool> = runs.iter().map(|r| stands_out(&s, r, &config)).collect();
        // Scan edge; closer run on the left; free on both sides; closer on the left;
        // invalid beam on the left.
        assert_eq!(out, [false, false, true, false, false]);
        let mut clean = ranges;
        clean[8] = inf;
        assert!(
            stands_out(&scan(&clean), &runs[4], &config),
            "27 m counts as background"
        );
    }
}
