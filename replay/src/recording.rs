//! A user's own recording: a ROS 2 bag ([`crate::rosbag`]) or a CARMEN log
//! ([`crate::carmen`]), loaded by its format into a [`DataSet`] with a one-line summary of
//! what was read and skipped, and the service settings for an indoor planar laser derived
//! from its scans ([`planar_laser_settings`]).
//!
//! Neither format carries ground truth: a recording's data set has odometry poses and raw
//! scans only, and the run is scored without truth (or on a relations file).

use crate::dataset::DataSet;
use crate::laser_odometry::{self, OdometryChoice};
use crate::rosbag::TopicChoice;
use crate::text::{DataError, Result};
use std::path::PathBuf;

/// Which recording, in which format.
#[derive(Debug, Clone, PartialEq)]
pub enum Recording {
    /// A rosbag2 folder (with `metadata.yaml`), one `.mcap` / `.db3` file or a ROS 1
    /// `.bag` file, with the topics and frames to read.
    Rosbag {
        /// The bag.
        path: PathBuf,
        /// Scan and odometry topics, odometry frames (`None`: chosen from the bag), and
        /// where the odometry comes from.
        topics: TopicChoice,
    },
    /// A CARMEN log (`.clf` / `.log`, gzipped or not).
    Carmen {
        /// The log file.
        path: PathBuf,
        /// Where the odometry comes from.
        odometry: OdometryChoice,
    },
}

/// A recording read into messages.
#[derive(Debug, Clone)]
pub struct Loaded {
    /// The messages, stamped from the recording's epoch.
    pub data: DataSet,
    /// What was read, in one line (counts, topics, frames, what was skipped).
    pub summary: String,
    /// What the reader noticed and the user should know (a missing mount, repaired stamps).
    pub warnings: Vec<String>,
}

impl Recording {
    /// Makes `data`'s odometry from its scans where [`OdometryChoice::Laser`] asks for it
    /// (slow: every scan is matched), saying so at the end of `summary` and in `warnings`
    /// when many scans did not match; does nothing otherwise.
    pub fn finish(&self, data: &mut DataSet, summary: &mut String, warnings: &mut Vec<String>) {
        if self.odometry() != OdometryChoice::Laser {
            return;
        }
        let (odometry, counts) = laser_odometry::from_scans(data, usable_range(data));
        data.odometry = odometry;
        *summary += &format!(
            " · odometry from the laser: {} of {} scans matched, {} in the local map",
            counts.matched, counts.scans, counts.inserted
        );
        // Every scan after the first should match; a few misses are rounding.
        let missed = counts.scans.saturating_sub(counts.matched + 1);
        if missed * 20 > counts.scans {
            warnings.push(format!(
                "{}: odometry from the laser: {missed} of {} scans matched nothing in their \
                 window and kept the pose predicted at constant velocity (the robot moved \
                 faster than the window between two scans, or saw too little structure)",
                self.path().display(),
                counts.scans
            ));
        }
    }

    /// Reads the recording; with [`OdometryChoice::Laser`] its data set has no odometry
    /// yet ([`Recording::finish`] makes it, slowly, so the launcher only reads).
    ///
    /// # Errors
    /// The reader's [`DataError`]: a missing, truncated or malformed file (named, with
    /// the line or the topic and message index), no scan topic, ambiguous topics.
    pub fn read(&self) -> Result<Loaded> {
        let mut loaded = match self {
            Self::Rosbag { path, topics } => {
                let bag = crate::rosbag::load(path, topics)?;
                Loaded {
                    summary: bag.summary(),
                    warnings: bag.warnings.clone(),
                    data: bag.data,
                }
            }
            Self::Carmen { path, .. } => {
                let log = crate::carmen::load(path)?;
                Loaded {
                    summary: log.to_string(),
                    warnings: log.warnings,
                    data: log.data,
                }
            }
        };
        if loaded.data.raw_scans.is_empty() {
            return Err(DataError::Unusable(format!(
                "{}: no laser scan in the recording",
                self.path().display()
            )));
        }
        if self.odometry() == OdometryChoice::Recorded
            && let Some(still) = still_odometry(&loaded.data)
        {
            loaded
                .warnings
                .push(format!("{}: {still}", self.path().display()));
        }
        Ok(loaded)
    }

    /// The file or folder read.
    pub fn path(&self) -> &std::path::Path {
        match self {
            Self::Rosbag { path, .. } | Self::Carmen { path, .. } => path,
        }
    }

    /// Where the odometry comes from.
    pub fn odometry(&self) -> OdometryChoice {
        match self {
            Self::Rosbag { topics, .. } => topics.odometry,
            Self::Carmen { odometry, .. } => *odometry,
        }
    }
}

/// How far the odometry must move from its first pose, at most, for a recording to
/// count as never moving (m, rad): a standing robot's odometry noise stays well inside.
const STILL_ODOMETRY: (f64, f64) = (0.01, 0.01);

/// Why the run will map little, when the odometry never moves while the scans go on for
/// more than a minute (a laser-only log, or an odometry source that publishes zeros):
/// grid FastSLAM maps a scan once the odometry has moved (`[grid] keyframe_distance`,
/// `keyframe_angle`), so the map holds the first scan alone. `None` otherwise.
fn still_odometry(data: &DataSet) -> Option<String> {
    let first = data.odometry.first()?;
    let moved = data.odometry.iter().any(|o| {
        let turned = fastslam_estimation::wrap_angle(o.theta - first.theta).abs();
        (o.x - first.x).hypot(o.y - first.y) > STILL_ODOMETRY.0 || turned > STILL_ODOMETRY.1
    });
    let stamps = data.raw_scans.iter().map(|s| s.header.header.stamp_ns);
    let (start, end) = (stamps.clone().min()?, stamps.max()?);
    let seconds = (end - start) as f64 * 1e-9;
    (!moved && seconds > 60.0).then(|| {
        format!(
            "the odometry never moves ({} poses, within {} m and {} rad of the first, while \
             the scans go on for {seconds:.0} s): grid FastSLAM maps a scan once the odometry \
             has moved, so the map will hold the first scan alone; replay the recording with \
             the robot's odometry (an Odometry topic, or tf from the odometry frame to the \
             base), or with --odometry laser to make it from the scans",
            data.odometry.len(),
            STILL_ODOMETRY.0,
            STILL_ODOMETRY.1
        )
    })
}

/// Cell size of the planar-laser grid (m): GMapping's `delta`, fine enough for indoor
/// walls a 1° laser resolves at a few metres.
pub const GRID_RESOLUTION_M: f64 = 0.05;

/// Scan points the matcher uses per scan, at most: the beam stride is the beam count
/// over this, so a 361-beam and a 1 081-beam laser cost the matcher alike.
pub const MATCH_POINTS: usize = 180;

/// How far a beam's end point is used (in cells of the grid at the beam spacing): a
/// beam is traced only as far as neighbouring beams' ends lie at most this many cells
/// apart, `range ≤ SPACING_CELLS · resolution / angle_increment`.
pub const SPACING_CELLS: f64 = 10.0;

/// The sensor-derived part of the service settings for an indoor planar laser, from the
/// recording's scans and mount (`[grid]`, `[map.matching]`, `[laser]` keys), to merge
/// into the `planar-laser` profile's fixed choices:
///
/// - `grid.resolution` = [`GRID_RESOLUTION_M`];
/// - `grid.max_range` = the shorter of the sensor's `range_max` and the range at which
///   neighbouring beams' ends lie [`SPACING_CELLS`] cells apart (28.6 m for a 1° laser,
///   57 m for 0.5°): beyond it a beam's end says little about one cell;
/// - `grid.beam_stride` and `map.matching.stride` = beams / [`MATCH_POINTS`] (at least 1);
/// - `laser.mount` = the recording's laser pose on the base.
///
/// # Errors
/// [`DataError::Unusable`] when the data set has no scan.
pub fn planar_laser_settings(data: &DataSet) -> Result<toml::Table> {
    if data.raw_scans.is_empty() {
        return Err(DataError::Unusable(
            "no laser scan to derive settings from".into(),
        ));
    }
    let beams = (data.raw_scans.iter())
        .map(|s| s.items.len())
        .max()
        .unwrap_or(0);
    let max_range = usable_range(data);
    let stride = (beams / MATCH_POINTS).max(1) as i64;
    let round = |v: f64| (v * 1000.0).round() / 1000.0;
    let m = data.laser_mount;
    let text = format!(
        "[grid]\nresolution = {GRID_RESOLUTION_M:?}\nmax_range = {:?}\nbeam_stride = {stride}\n\
         [map.matching]\nstride = {stride}\n[laser]\nmount = [{:?}, {:?}, {:?}]\n",
        round(max_range),
        m.x,
        m.y,
        m.theta
    );
    toml::from_str(&text).map_err(|e| DataError::Unusable(format!("derived settings: {e}")))
}

/// How far a beam of `data`'s laser is used (m): the shorter of the sensor's `range_max`
/// and the range at which neighbouring beams' ends lie [`SPACING_CELLS`] cells apart
/// (the latter alone when no scan states a finite `range_max`).
fn usable_range(data: &DataSet) -> f64 {
    let increment = (data.raw_scans.first()).map_or(1e-6, |s| {
        f64::from(s.header.angle_increment.abs()).max(1e-6)
    });
    let range_max = (data.raw_scans.iter())
        .map(|s| f64::from(s.header.range_max))
        .filter(|r| r.is_finite() && *r > 0.0)
        .fold(0.0, f64::max);
    let spacing_limit = SPACING_CELLS * GRID_RESOLUTION_M / increment;
    if range_max > 0.0 {
        range_max.min(spacing_limit)
    } else {
        spacing_limit
    }
}

/// Merges `overlay` into `base`, key by key (tables recursively; `overlay` wins).
pub fn merge_tables(base: &mut toml::Table, overlay: &toml::Table) {
    for (key, value) in overlay {
        match (base.get_mut(key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge_tables(b, o),
            _ => {
                base.insert(key.clone(), value.clone());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dataset::RawScan;
    use fastslam_estimation::Pose2;
    use fastslam_protocol::LaserScanHeader;

    fn scan(beams: usize, increment: f32, range_max: f32) -> RawScan {
        RawScan {
            header: LaserScanHeader {
                angle_min: -std::f32::consts::FRAC_PI_2,
                angle_increment: increment,
                range_max,
                ranges: beams as u32,
                ..LaserScanHeader::default()
            },
            items: vec![1.0; beams],
        }
    }

    #[test]
    fn settings_follow_the_sensor() {
        let data = DataSet {
            raw_scans: vec![scan(181, 1f32.to_radians(), 81.8)],
            laser_mount: Pose2::new(0.2, -0.1, 0.3),
            ..DataSet::default()
        };
        let t = planar_laser_settings(&data).unwrap();
        let grid = t["grid"].as_table().unwrap();
        assert!((grid["max_range"].as_float().unwrap() - 28.648).abs() < 2e-3);
        assert_eq!(grid["beam_stride"].as_integer(), Some(1));
        let mount = t["laser"]["mount"].as_array().unwrap();
        assert_eq!(mount[0].as_float(), Some(0.2));
        assert!((mount[2].as_float().unwrap() - 0.3).abs() < 1e-12);
        // A 0.5° laser with a 30 m range: the range limits, and every other beam is used.
        let data = DataSet {
            raw_scans: vec![scan(361, 0.5f32.to_radians(), 30.0)],
            ..DataSet::default()
        };
        let t = planar_laser_settings(&data).unwrap();
        assert_eq!(t["grid"]["max_range"].as_float(), Some(30.0));
        assert_eq!(t["map"]["matching"]["stride"].as_integer(), Some(2));
        assert!(planar_laser_settings(&DataSet::default()).is_err());
    }

    #[test]
    fn odometry_that_never_moves_while_scans_go_on_is_named() {
        let at = |seconds: u64, x: f64| {
            let mut scan = scan(10, 0.1, 10.0);
            scan.header.header.stamp_ns = seconds * 1_000_000_000;
            let odometry = fastslam_protocol::Odometry {
                x,
                ..fastslam_protocol::Odometry::default()
            };
            (scan, odometry)
        };
        let data = |xs: &[(u64, f64)]| {
            let (raw_scans, odometry) = xs.iter().map(|&(t, x)| at(t, x)).unzip();
            DataSet {
                raw_scans,
                odometry,
                ..DataSet::default()
            }
        };
        let still = still_odometry(&data(&[(0, 0.0), (30, 0.005), (90, 0.0)])).unwrap();
        assert!(
            still.starts_with("the odometry never moves (3 poses"),
            "{still}"
        );
        assert!(still.contains("for 90 s"), "{still}");
        assert_eq!(
            still_odometry(&data(&[(0, 0.0), (90, 0.02)])),
            None,
            "it moves"
        );
        assert_eq!(
            still_odometry(&data(&[(0, 0.0), (50, 0.0)])),
            None,
            "a short one"
        );
    }

    #[test]
    fn overlay_wins_key_by_key() {
        let mut base: toml::Table =
            toml::from_str("[grid]\nresolution = 0.1\nmargin = 5.0").unwrap();
        let overlay: toml::Table = toml::from_str("[grid]\nresolution = 0.05").unwrap();
        merge_tables(&mut base, &overlay);
        assert_eq!(base["grid"]["resolution"].as_float(), Some(0.05));
        assert_eq!(base["grid"]["margin"].as_float(), Some(5.0));
    }
}
