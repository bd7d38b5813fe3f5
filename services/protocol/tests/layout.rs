//! The README's layout tables are the contract for publishers in other languages; this
//! test keeps them equal to the Rust types (type name, size, alignment, every offset).

mod readme;

use fastslam_protocol::*;
use iceoryx2::prelude::ZeroCopySend;
use readme::{README, documented_fields, documented_sizes};
use std::mem::{align_of, offset_of, size_of};

/// One documented type: its name, size, alignment and field offsets as Rust lays them out.
struct Layout {
    name: &'static str,
    size: usize,
    align: usize,
    fields: Vec<(&'static str, usize)>,
}

macro_rules! layout {
    ($t:ty: $($($f:ident).+),+) => {
        Layout {
            // SAFETY: type_name only returns the static name the derive generated.
            name: unsafe { <$t as ZeroCopySend>::type_name() },
            size: size_of::<$t>(),
            align: align_of::<$t>(),
            fields: vec![$((stringify!($($f).+), offset_of!($t, $($f).+))),+],
        }
    };
}

fn rust_layouts() -> Vec<Layout> {
    vec![
        layout!(GroundTruth: header.stamp_ns, header.seq, x, y, theta, v, omega, steering),
        layout!(Odometry: header.stamp_ns, header.seq, v, omega, steering, x, y, theta),
        layout!(ObservationsHeader: header.stamp_ns, header.seq, count, reserved, max_range, min_bearing, max_bearing),
        layout!(Observation: range, bearing, diameter, id),
        layout!(PoseEstimate: header.stamp_ns, header.seq, x, y, theta, covariance),
        layout!(LandmarkMapHeader: header.stamp_ns, header.seq, count, reserved),
        layout!(MapLandmark: id, x, y, cov_xx, cov_xy, cov_yy, observations),
        layout!(MapRequest: reserved),
        layout!(StreamCovered: stream, reserved, covered_ns),
        layout!(Checkpointed: header.stamp_ns, header.seq, stream_count, resume, covered),
        layout!(ClientNotice: header.stamp_ns, header.seq, restarts, recorded, ended, finished),
        layout!(StreamStatus: stream, queued, last_input_ns, quiet, reserved),
        layout!(ServiceStatus: header.stamp_ns, header.seq, steps, resamplings, n_eff, particles,
            distinct_particles, landmarks, step_time_ns, flags, nis_dof, rejections, nis,
            stream_count, torn_solves, streams, noise_profile, noise_fitted, noise_fit, noise_suspect),
        layout!(EndOfStream: header.stamp_ns, header.seq, stream, reserved),
        layout!(LaserScanHeader: header.stamp_ns, header.seq, angle_min, angle_increment,
            time_increment, scan_time, range_min, range_max, ranges, intensities),
        layout!(OccupancyGridHeader: header.stamp_ns, header.seq, resolution, origin_x, origin_y,
            origin_theta, width, height),
        layout!(TrajectoryHeader: header.stamp_ns, header.seq, count, solves, chi2_per_dof),
        layout!(TrajectoryPose: stamp_ns, x, y, theta),
        layout!(ParticlesHeader: header.stamp_ns, header.seq, count, reserved),
        layout!(Particle: x, y, theta, weight),
    ]
}

#[test]
fn readme_tables_match_the_rust_layouts() {
    let readme = README;
    let sizes = documented_sizes(readme);
    let rust = rust_layouts();
    assert_eq!(
        sizes.len(),
        rust.len(),
        "every type documented once: {sizes:?}"
    );
    for t in &rust {
        let doc = sizes
            .iter()
            .find(|(n, ..)| n == t.name)
            .unwrap_or_else(|| panic!("{} not documented", t.name));
        assert_eq!(
            (doc.1, doc.2),
            (t.size, t.align),
            "size/alignment of {}",
            t.name
        );
        let fields: Vec<(String, usize)> = t
            .fields
            .iter()
            .map(|(f, o)| (f.replace(' ', ""), *o))
            .collect();
        assert_eq!(
            documented_fields(readme, t.name),
            fields,
            "fields of {}",
            t.name
        );
    }
}

#[test]
fn type_names_are_explicit_and_stable() {
    for t in rust_layouts() {
        assert!(
            t.name.starts_with("fastslam::"),
            "{} must have an explicit #[type_name]",
            t.name
        );
    }
}
