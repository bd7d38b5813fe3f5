//! The relation metric of the Freiburg 2D-lidar SLAM benchmark (Kümmerle et al., "On
//! measuring the accuracy of SLAM algorithms", Autonomous Robots 2009), as its
//! `metricEvaluator` defines it.
//!
//! A relations file lists pairs of times `t1 t2` with the reference motion between them:
//! the pose at `t2` in the frame of the pose at `t1`. A trajectory is scored by taking its
//! poses nearest to `t1` and `t2` (each within a gap, [`MAX_GAP_S`]), forming its own
//! motion `δ = p₁⁻¹ ⊕ p₂` and subtracting the reference component-wise (the angle
//! wrapped to (−π, π]): the translational error is `√(Δx² + Δy²)` (m), the rotational
//! error `|Δθ|` (°). The errors and their squares are summarised by their mean and sample
//! standard deviation (N − 1). Relations without a pose near one of their times are not
//! scored. Scoring needs no alignment: relative motions do not depend on the frame.
//!
//! **Which body's poses.** A relation is the motion of the body whose poses it was
//! measured on. The benchmark's relations come from aligning laser scans, so they are the
//! laser's motions; a trajectory of the robot's base is moved onto the laser first
//! (`pose ∘ mount`, [`score_stamped`]'s `body`). The laser's motion is
//! `mount⁻¹ ∘ δ ∘ mount` of the base's motion `δ`: the same only where the mount is the
//! identity; otherwise it differs by the mount's lever turned through the relation's
//! rotation, seen along the mount's heading.

use crate::align::Se2;
use crate::recording::StampedPose;
use crate::stats::{mean, std_dev};
use fastslam_estimation::wrap_angle;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The largest time between a relation's time and the trajectory pose taken for it (s).
pub const MAX_GAP_S: f64 = 0.1;

/// Whose motions a relations file holds, when a recording says where its laser sits on
/// the base.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum RelationsFrame {
    /// The laser's: relations measured by aligning scans, as the benchmark's.
    #[default]
    Laser,
    /// The base's, as the trajectories are published.
    Base,
}

impl RelationsFrame {
    /// The body to score on ([`score_stamped`]'s `body`) for a laser mounted at `mount`.
    pub fn body(self, mount: Se2) -> Se2 {
        match self {
            Self::Laser => mount,
            Self::Base => Se2::IDENTITY,
        }
    }
}

/// The reference motion between the poses at two times.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Relation {
    /// The first time, on the data set's clock (s).
    pub t1_s: f64,
    /// The second time (s).
    pub t2_s: f64,
    /// Forward displacement in the frame of the pose at `t1` (m).
    pub dx: f64,
    /// Leftward displacement in the frame of the pose at `t1` (m).
    pub dy: f64,
    /// Heading change (rad).
    pub dtheta: f64,
}

/// What can be wrong with a relations file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RelationsError {
    /// The file cannot be opened or read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// A line is not `t1 t2 x y z roll pitch yaw` of finite numbers.
    #[error("{path}:{line}: {reason}")]
    Malformed {
        /// The file.
        path: PathBuf,
        /// The line number, from 1.
        line: usize,
        /// What is wrong, with the offending text.
        reason: String,
    },
}

/// Reads a relations file: one relation per line, `t1 t2 x y z roll pitch yaw` (s, m,
/// rad; z, roll and pitch are ignored), `#` comment lines and blank lines skipped.
///
/// # Errors
/// [`RelationsError::Io`] when the file cannot be read; [`RelationsError::Malformed`]
/// with the line number for a line without exactly eight finite numbers.
pub fn read_relations(path: &Path) -> Result<Vec<Relation>, RelationsError> {
    let text = std::fs::read_to_string(path).map_err(|source| RelationsError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let mut relations = Vec::new();
    for (index, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let malformed = |reason: String| RelationsError::Malformed {
            path: path.to_path_buf(),
            line: index + 1,
            reason,
        };
        let fields: Vec<&str> = line.split_ascii_whitespace().collect();
        if fields.len() != 8 {
            let found = fields.len();
            return Err(malformed(format!(
                "expected 8 fields, found {found}: `{line}`"
            )));
        }
        let mut values = [0.0; 8];
        for (k, (value, field)) in values.iter_mut().zip(&fields).enumerate() {
            *value = (field.parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    malformed(format!("field {} is not a finite number: `{field}`", k + 1))
                })?;
        }
        let [t1_s, t2_s, dx, dy, _, _, _, dtheta] = values;
        relations.push(Relation {
            t1_s,
            t2_s,
            dx,
            dy,
            dtheta,
        });
    }
    Ok(relations)
}

/// The relation errors of a trajectory: mean and sample standard deviation of the
/// translational and rotational errors and of their squares.
#[derive(Serialize, Deserialize, Debug, Clone, Copy, PartialEq)]
pub struct RelationErrors {
    /// Relations scored.
    pub count: usize,
    /// Mean translational error (m).
    pub trans_mean_m: f64,
    /// Sample standard deviation of the translational error (m).
    pub trans_std_m: f64,
    /// Mean squared translational error (m²).
    pub trans_sq_mean_m2: f64,
    /// Sample standard deviation of the squared translational error (m²).
    pub trans_sq_std_m2: f64,
    /// Mean rotational error (°).
    pub rot_mean_deg: f64,
    /// Sample standard deviation of the rotational error (°).
    pub rot_std_deg: f64,
    /// Mean squared rotational error (°²).
    pub rot_sq_mean_deg2: f64,
    /// Sample standard deviation of the squared rotational error (°²).
    pub rot_sq_std_deg2: f64,
}

/// Scores `trajectory`, poses at times on the relations' clock (s) sorted by time,
/// against `relations`, taking for each time the nearest pose within `max_gap_s` (see
/// the module doc; the benchmark uses [`MAX_GAP_S`]). `None` when no relation could be
/// scored; `count` says how many were.
pub fn score(
    relations: &[Relation],
    trajectory: &[(f64, Se2)],
    max_gap_s: f64,
) -> Option<RelationErrors> {
    let (mut trans, mut rot) = (Vec::new(), Vec::new());
    for r in relations {
        let (Some(p1), Some(p2)) = (
            nearest(trajectory, r.t1_s, max_gap_s),
            nearest(trajectory, r.t2_s, max_gap_s),
        ) else {
            continue;
        };
        let moved = p1.inverse().compose(&p2);
        trans.push((moved.x - r.dx).hypot(moved.y - r.dy));
        rot.push(wrap_angle(moved.theta - r.dtheta).abs().to_degrees());
    }
    if trans.is_empty() {
        return None;
    }
    let squares = |xs: &[f64]| xs.iter().map(|x| x * x).collect::<Vec<f64>>();
    let (trans_sq, rot_sq) = (squares(&trans), squares(&rot));
    Some(RelationErrors {
        count: trans.len(),
        trans_mean_m: mean(&trans),
        trans_std_m: std_dev(&trans),
        trans_sq_mean_m2: mean(&trans_sq),
        trans_sq_std_m2: std_dev(&trans_sq),
        rot_mean_deg: mean(&rot),
        rot_std_deg: std_dev(&rot),
        rot_sq_mean_deg2: mean(&rot_sq),
        rot_sq_std_deg2: std_dev(&rot_sq),
    })
}

/// [`score`] for poses stamped in nanoseconds since a data set's epoch `epoch_s` (s on
/// the relations' clock): pose `p` is at `epoch_s + p.stamp_ns · 10⁻⁹`. The relations
/// are of `body`, given by its pose on the trajectory's frame (the laser's mount on the
/// base; [`Se2::IDENTITY`]: the trajectory's own): each pose is scored as `p ∘ body`.
pub fn score_stamped(
    relations: &[Relation],
    poses: &[StampedPose],
    epoch_s: f64,
    body: &Se2,
    max_gap_s: f64,
) -> Option<RelationErrors> {
    // `p ∘ identity` is `p` exactly, without the rounding of composing.
    let on_body = |p: &StampedPose| {
        if *body == Se2::IDENTITY {
            Se2::of(p)
        } else {
            Se2::of(p).compose(body)
        }
    };
    let trajectory: Vec<(f64, Se2)> = (poses.iter())
        .map(|p| (epoch_s + p.stamp_ns as f64 * 1e-9, on_body(p)))
        .collect();
    score(relations, &trajectory, max_gap_s)
}

/// The pose of `trajectory` (sorted by time) nearest to `t_s`, if within `max_gap_s`;
/// the earlier one of two equally near.
fn nearest(trajectory: &[(f64, Se2)], t_s: f64, max_gap_s: f64) -> Option<Se2> {
    let after = trajectory.partition_point(|(t, _)| *t < t_s);
    let candidates = [after.checked_sub(1), Some(after)];
    (candidates.into_iter().flatten())
        .filter_map(|i| trajectory.get(i))
        .map(|&(t, pose)| ((t - t_s).abs(), pose))
        .filter(|(gap, _)| *gap <= max_gap_s)
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, pose)| pose)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn se2(x: f64, y: f64, theta: f64) -> Se2 {
        Se2 { x, y, theta }
    }

    /// A drive around a circle of radius 5 m at 10 Hz for `n` poses.
    fn circle(n: usize) -> Vec<(f64, Se2)> {
        (0..n)
            .map(|k| {
                let t = k as f64 * 0.1;
                let a = 0.2 * t;
                (
                    100.0 + t,
                    se2(5.0 * a.sin(), 5.0 - 5.0 * a.cos(), wrap_angle(a)),
                )
            })
            .collect()
    }

    /// The exact relation between poses `i` and `j` of `trajectory`.
    fn exact(trajectory: &[(f64, Se2)], i: usize, j: usize) -> Relation {
        let moved = trajectory[i].1.inverse().compose(&trajectory[j].1);
        Relation {
            t1_s: trajectory[i].0,
            t2_s: trajectory[j].0,
            dx: moved.x,
            dy: moved.y,
            dtheta: moved.theta,
        }
    }

    #[test]
    fn the_exact_trajectory_scores_zero() {
        let trajectory = circle(400);
        let relations: Vec<Relation> = (0..390)
            .step_by(7)
            .map(|i| exact(&trajectory, i, (i * 13 + 5) % 400))
            .collect();
        let e = score(&relations, &trajectory, MAX_GAP_S).unwrap();
        assert_eq!(e.count, relations.len());
        assert!(e.trans_mean_m < 1e-12 && e.rot_mean_deg < 1e-9, "{e:?}");
        assert!(e.trans_std_m < 1e-12 && e.rot_sq_mean_deg2 < 1e-12, "{e:?}");
    }

    #[test]
    fn a_known_perturbation_gives_the_hand_computed_errors() {
        let trajectory = [(1.0, se2(1.0, 1.0, 0.0)), (2.0, se2(1.0, 2.0, 0.0))];
        let mut relation = exact(&trajectory, 0, 1);
        // Off by (0.3, 0.4) m and 0.1 rad: 0.5 m and 5.7296°.
        relation.dx += 0.3;
        relation.dy -= 0.4;
        relation.dtheta += 0.1;
        // The same, off by (0.6, 0.8) m: 1 m, no rotation.
        let mut other = exact(&trajectory, 0, 1);
        other.dx -= 0.6;
        other.dy += 0.8;
        // Times a little off still take the nearest poses.
        other.t1_s += 0.04;
        let e = score(&[relation, other], &trajectory, MAX_GAP_S).unwrap();
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
        assert_eq!(e.count, 2);
        assert!(close(e.trans_mean_m, 0.75) && close(e.trans_std_m, 0.125_f64.sqrt()));
        assert!(close(e.trans_sq_mean_m2, 0.625) && close(e.trans_sq_std_m2, 0.28125_f64.sqrt()));
        let deg = 0.1_f64.to_degrees();
        assert!(close(e.rot_mean_deg, deg / 2.0) && close(e.rot_std_deg, deg / 2.0_f64.sqrt()));
        assert!(close(e.rot_sq_mean_deg2, deg * deg / 2.0));
        assert!(close(e.rot_sq_std_deg2, deg * deg / 2.0_f64.sqrt()));
    }

    #[test]
    fn relations_without_a_pose_within_the_gap_are_not_scored() {
        let trajectory = circle(20);
        let mut far = exact(&trajectory, 2, 10);
        far.t2_s = trajectory[19].0 + 0.15;
        far.dx += 100.0;
        let mut early = exact(&trajectory, 0, 4);
        early.t1_s -= 0.11;
        let mut edge = exact(&trajectory, 0, 4);
        edge.t1_s -= 0.099;
        let good = exact(&trajectory, 1, 5);
        let e = score(&[far, early, good, edge], &trajectory, MAX_GAP_S).unwrap();
        assert_eq!(e.count, 2, "{e:?}");
        assert!(
            e.trans_mean_m < 1e-12,
            "the poses nearest to the times are taken: {e:?}"
        );
        assert_eq!(score(&[far], &trajectory, MAX_GAP_S), None);
        assert_eq!(score(&[good], &[], MAX_GAP_S), None);
    }

    #[test]
    fn angles_are_wrapped() {
        // Headings on either side of ±π: the motion turns by 0.08 rad, not by 2π − 0.08.
        let trajectory = [(0.0, se2(0.0, 0.0, 3.1)), (1.0, se2(0.0, 0.0, -3.1))];
        let turn = 2.0 * std::f64::consts::PI - 6.2;
        let mut r = exact(&trajectory, 0, 1);
        assert!((r.dtheta - turn).abs() < 1e-12);
        r.dtheta = turn - 2.0 * std::f64::consts::TAU;
        let e = score(&[r], &trajectory, MAX_GAP_S).unwrap();
        assert!(e.rot_mean_deg < 1e-9, "{e:?}");
        r.dtheta = -std::f64::consts::PI + 0.01;
        let e = score(&[r], &trajectory, MAX_GAP_S).unwrap();
        // turn + π − 0.01 wraps to turn − π − 0.01.
        let expected = (std::f64::consts::PI - turn + 0.01).to_degrees();
        assert!((e.rot_mean_deg - expected).abs() < 1e-9, "{e:?}");
    }

    #[test]
    fn stamped_poses_are_placed_on_the_relations_clock() {
        let trajectory = circle(30);
        let poses: Vec<StampedPose> = (trajectory.iter())
            .map(|(t, p)| StampedPose {
                stamp_ns: ((t - 90.0) * 1e9).round() as u64,
                x: p.x,
                y: p.y,
                theta: p.theta,
            })
            .collect();
        let mut r = exact(&trajectory, 3, 20);
        r.dy += 0.25;
        let e = score_stamped(&[r], &poses, 90.0, &Se2::IDENTITY, MAX_GAP_S).unwrap();
        assert!((e.trans_mean_m - 0.25).abs() < 1e-9, "{e:?}");
    }

    #[test]
    fn a_base_trajectory_is_scored_on_the_relations_of_its_laser() {
        // The base drives the circle; the laser sits 0.4 m ahead and 0.1 m to the left,
        // turned by 0.3 rad. Relations measured on the laser's poses are met exactly by
        // the base's poses moved onto the laser, and missed by the base's own.
        let mount = Se2 {
            x: 0.4,
            y: 0.1,
            theta: 0.3,
        };
        let base = circle(30);
        let laser: Vec<(f64, Se2)> = base.iter().map(|(t, p)| (*t, p.compose(&mount))).collect();
        let relations: Vec<Relation> = (0..10).map(|i| exact(&laser, i, i + 20)).collect();
        let poses: Vec<StampedPose> = (base.iter())
            .map(|(t, p)| StampedPose {
                stamp_ns: (t * 1e9).round() as u64,
                x: p.x,
                y: p.y,
                theta: p.theta,
            })
            .collect();
        let on_laser = score_stamped(&relations, &poses, 0.0, &mount, MAX_GAP_S).unwrap();
        assert!(on_laser.trans_mean_m < 1e-9, "{on_laser:?}");
        let on_base = score_stamped(&relations, &poses, 0.0, &Se2::IDENTITY, MAX_GAP_S).unwrap();
        assert!(on_base.trans_mean_m > 0.05, "{on_base:?}");
        assert!(
            on_base.rot_mean_deg < 1e-9,
            "rotations do not depend on the body"
        );
    }

    #[test]
    fn relation_files_skip_comments_and_name_bad_lines() {
        let path = std::env::temp_dir().join(format!("relations-{}.txt", std::process::id()));
        let text = "# t1 t2 x y z roll pitch yaw\n\n1 2 0.5 -0.25 0 0 0 0.125\n3 4 1 1 0 0 0\n";
        std::fs::write(&path, text).unwrap();
        let err = read_relations(&path).unwrap_err().to_string();
        assert!(
            err.ends_with(":4: expected 8 fields, found 7: `3 4 1 1 0 0 0`"),
            "{err}"
        );
        std::fs::write(&path, &text[..text.len() - 14]).unwrap();
        let relations = read_relations(&path).unwrap();
        let expected = Relation {
            t1_s: 1.0,
            t2_s: 2.0,
            dx: 0.5,
            dy: -0.25,
            dtheta: 0.125,
        };
        assert_eq!(relations, [expected]);
        std::fs::write(&path, "1 2 x 0 0 0 0 0\n").unwrap();
        let err = read_relations(&path).unwrap_err().to_string();
        assert!(
            err.contains(":1: field 3 is not a finite number: `x`"),
            "{err}"
        );
        std::fs::remove_file(&path).unwrap();
        assert!(matches!(
            read_relations(&path),
            Err(RelationsError::Io { .. })
        ));
    }
}
