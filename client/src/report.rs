//! The run folder: `metrics.json`, the `metrics.csv` time series, TUM trajectories
//! (readable by `evo`), the maps as CSV, the occupancy grid when the service sent one
//! (see [`crate::occupancy`]), and the pictures (`METRICS.md` has the schema).

use crate::metrics::Metrics;
use crate::plot::{self, ErrorPlot, TrajectoryPlot};
use crate::recording::{Recording, StampedPose};
use crate::timeline::{CSV_COLUMNS, timeline};
use fastslam_protocol::MapLandmark;
use fastslam_protocol::landmarks::map_csv;
use std::fs;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Files of a run folder.
pub mod files {
    /// The metrics (see [`crate::Metrics`]).
    pub const METRICS: &str = "metrics.json";
    /// The service's estimates, TUM format.
    pub const ESTIMATE_TUM: &str = "estimate.tum";
    /// Ground truth, TUM format (only when the run has ground truth).
    pub const TRUTH_TUM: &str = "truth.tum";
    /// Dead-reckoned odometry, TUM format.
    pub const DEAD_RECKONING_TUM: &str = "dead_reckoning.tum";
    /// The achievable-accuracy reference's trajectory (only when there is one).
    pub const REFERENCE_TUM: &str = "reference.tum";
    /// The smoothing back-end's trajectory (only when the service ran one).
    pub const SMOOTHED_TUM: &str = "smoothed.tum";
    /// The smoothing back-end's map (only when the service ran one).
    pub const SMOOTHED_MAP_CSV: &str = "smoothed_map.csv";
    /// The service's final landmark map.
    pub const MAP_CSV: &str = "map.csv";
    /// The true landmark map (only when the run has ground truth).
    pub const TRUE_MAP_CSV: &str = "true_map.csv";
    /// One row per estimate (see [`crate::timeline`]).
    pub const METRICS_CSV: &str = "metrics.csv";
    /// Trajectories over the map (`.svg` and `.png`).
    pub const TRAJECTORY_PICTURE: &str = "trajectory";
    /// Errors and NEES over time (`.svg` and `.png`).
    pub const ERRORS_PICTURE: &str = "errors";
    /// Every message the client received and the metrics, MCAP (see [`crate::mcap`]).
    pub const MCAP: &str = "run.mcap";
}

/// Writes the run folder `dir` (created if needed); without ground truth, without the
/// files of the truth.
///
/// # Errors
/// When a file cannot be written.
pub fn write(dir: &Path, rec: &Recording, metrics: &Metrics) -> std::io::Result<()> {
    fs::create_dir_all(dir)?;
    let json = serde_json::to_string_pretty(metrics).map_err(std::io::Error::other)?;
    fs::write(dir.join(files::METRICS), json + "\n")?;
    let estimates: Vec<StampedPose> = rec.estimates.iter().map(|e| e.pose).collect();
    write_tum(&dir.join(files::ESTIMATE_TUM), &estimates)?;
    if !rec.without_truth {
        write_tum(&dir.join(files::TRUTH_TUM), &rec.truth)?;
    }
    write_tum(&dir.join(files::DEAD_RECKONING_TUM), &rec.dead_reckoning)?;
    if !rec.reference.is_empty() {
        write_tum(&dir.join(files::REFERENCE_TUM), &rec.reference)?;
    }
    if !rec.smoothed.is_empty() {
        write_tum(&dir.join(files::SMOOTHED_TUM), &rec.smoothed)?;
        write_map(&dir.join(files::SMOOTHED_MAP_CSV), &rec.smoothed_map)?;
    }
    write_map(&dir.join(files::MAP_CSV), &rec.map)?;
    if !rec.without_truth {
        write_map(&dir.join(files::TRUE_MAP_CSV), &rec.true_map)?;
    }
    if let Some((header, cells)) = &rec.grid {
        crate::occupancy::write(dir, header, cells)?;
    }
    let rows = timeline(rec);
    write_timeline(&dir.join(files::METRICS_CSV), &rows)?;
    let trajectory = TrajectoryPlot {
        truth: &rec.truth,
        estimate: &estimates,
        dead_reckoning: &rec.dead_reckoning,
        reference: &rec.reference,
        smoothed: &rec.smoothed,
        map: &rec.map,
        true_map: &rec.true_map,
    };
    plot::save(&trajectory, dir, files::TRAJECTORY_PICTURE)?;
    plot::save(&ErrorPlot { rows: &rows }, dir, files::ERRORS_PICTURE)
}

/// The time series as CSV: a header row of [`CSV_COLUMNS`], then one row per estimate;
/// unknown values are empty cells.
pub fn write_timeline(path: &Path, rows: &[crate::timeline::Row]) -> std::io::Result<()> {
    let mut w = BufWriter::new(fs::File::create(path)?);
    writeln!(w, "{}", CSV_COLUMNS.join(","))?;
    for r in rows {
        let cells: Vec<String> = r
            .values()
            .iter()
            .map(|v| {
                if v.is_finite() {
                    v.to_string()
                } else {
                    String::new()
                }
            })
            .collect();
        writeln!(w, "{}", cells.join(","))?;
    }
    w.flush()
}

/// TUM trajectory: `t x y z qx qy qz qw` per line, z = 0 and the heading as a rotation
/// about +z (q = (0, 0, sin θ/2, cos θ/2)).
pub fn write_tum(path: &Path, poses: &[StampedPose]) -> std::io::Result<()> {
    let mut w = BufWriter::new(fs::File::create(path)?);
    writeln!(w, "# timestamp tx ty tz qx qy qz qw")?;
    for p in poses {
        let (s, c) = (p.theta / 2.0).sin_cos();
        let t = p.stamp_ns as f64 * 1e-9;
        writeln!(w, "{t:.9} {:.9} {:.9} 0 0 0 {s:.12} {c:.12}", p.x, p.y)?;
    }
    w.flush()
}

/// Landmark map as CSV with a header row ([`map_csv`], the format saved maps share).
pub fn write_map(path: &Path, map: &[MapLandmark]) -> std::io::Result<()> {
    fs::write(path, map_csv(map))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tum_lines_have_eight_numbers_and_unit_quaternions() {
        let dir = std::env::temp_dir().join(format!("tum-test-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let path = dir.join("t.tum");
        let poses = [StampedPose {
            stamp_ns: 1_500_000_000,
            x: 1.0,
            y: 2.0,
            theta: 1.0,
        }];
        write_tum(&path, &poses).unwrap();
        let text = fs::read_to_string(&path).unwrap();
        let line = text.lines().find(|l| !l.starts_with('#')).unwrap();
        let v: Vec<f64> = line.split(' ').map(|x| x.parse().unwrap()).collect();
        assert_eq!(v.len(), 8);
        assert_eq!(v[0], 1.5);
        assert!((v[6].hypot(v[7]) - 1.0).abs() < 1e-9);
        assert!((2.0 * v[6].atan2(v[7]) - 1.0).abs() < 1e-9);
        fs::remove_dir_all(&dir).unwrap();
    }
}
