//! A raw 2D range scan as plain values (no IPC types): where each beam points and what it
//! measured, with the REP-117 reading of odd values. Landmark extraction
//! ([`crate::features`]) and grid mapping ([`crate::grid`]) both read scans through it.

/// One scan: beam `i` points at `angle_min + i · angle_increment` (rad, sensor frame,
/// counter-clockwise, 0 = forward) and measured `ranges[i]` (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RangeScan<'a> {
    /// Direction of the first beam (rad).
    pub angle_min: f64,
    /// Angle between consecutive beams (rad), > 0.
    pub angle_increment: f64,
    /// Shortest range the sensor measures (m).
    pub range_min: f64,
    /// Longest range the sensor measures (m); readings at or beyond it are no returns.
    pub range_max: f64,
    /// The readings (m).
    pub ranges: &'a [f32],
}

/// What one beam says (REP-117).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Beam {
    /// An obstacle at this range (m), within `[range_min, range_max)`.
    Hit(f64),
    /// Nothing within `range_max` (`+∞`, or a reading at or beyond `range_max`, such as
    /// a sensor's fixed "no return" value): the beam crossed free space.
    NoReturn,
    /// No usable information: NaN (invalid), `−∞` (too close) or below `range_min`.
    Invalid,
}

impl RangeScan<'_> {
    /// Number of beams.
    pub fn len(&self) -> usize {
        self.ranges.len()
    }

    /// True when the scan has no beam.
    pub fn is_empty(&self) -> bool {
        self.ranges.is_empty()
    }

    /// Direction of beam `i` (rad).
    pub fn angle(&self, i: usize) -> f64 {
        self.angle_min + i as f64 * self.angle_increment
    }

    /// True when the beams cover a full turn, so the first and last beam are neighbours.
    pub fn is_full_turn(&self) -> bool {
        self.ranges.len() as f64 * self.angle_increment >= std::f64::consts::TAU - 1e-6
    }

    /// What beam `i` measured; [`Beam::Invalid`] for an index past the end.
    pub fn beam(&self, i: usize) -> Beam {
        let Some(&r) = self.ranges.get(i) else {
            return Beam::Invalid;
        };
        let r = f64::from(r);
        if r.is_nan() || r < self.range_min {
            Beam::Invalid
        } else if r >= self.range_max {
            Beam::NoReturn
        } else {
            Beam::Hit(r)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn beams_follow_rep117() {
        let ranges = [
            5.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            0.05,
            30.0,
            81.91,
        ];
        let scan = RangeScan {
            angle_min: -1.0,
            angle_increment: 0.5,
            range_min: 0.1,
            range_max: 30.0,
            ranges: &ranges,
        };
        let beams: Vec<Beam> = (0..8).map(|i| scan.beam(i)).collect();
        use Beam::*;
        assert_eq!(
            beams,
            [
                Hit(5.0),
                NoReturn,
                Invalid,
                Invalid,
                Invalid,
                NoReturn,
                NoReturn,
                Invalid
            ]
        );
        assert_eq!(scan.angle(2), 0.0);
        assert!(!scan.is_full_turn());
    }
}
