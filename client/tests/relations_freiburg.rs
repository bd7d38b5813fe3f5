//! The relation metric checked on the Freiburg benchmark's own data: the raw odometry of
//! each log (the robot poses of its laser lines), read by the replay's CARMEN reader and
//! scored on the set's relations, must give the published raw-odometry errors
//! (`data/freiburg/README.md`) to the printed digits.

use fastslam_client::recording::StampedPose;
use fastslam_client::relations::{self, MAX_GAP_S, RelationErrors};
use fastslam_replay::carmen;
use std::path::PathBuf;

/// The set's folder in the repository.
fn folder(set: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("../data/freiburg/{set}"))
}

/// The raw odometry's errors on `set`: `(relations in the file, errors)`.
fn raw_odometry_errors(set: &str) -> (usize, RelationErrors) {
    let dir = folder(set);
    let log = carmen::load(&dir.join(format!("{set}.clf.gz"))).unwrap();
    println!("{log}");
    let relations = relations::read_relations(&dir.join(format!("{set}.relations"))).unwrap();
    let poses: Vec<StampedPose> = (log.data.odometry.iter())
        .map(|o| StampedPose {
            stamp_ns: o.header.stamp_ns,
            x: o.x,
            y: o.y,
            theta: o.theta,
        })
        .collect();
    let laser = log.data.laser_mount.into();
    let errors = relations::score_stamped(&relations, &poses, log.data.epoch_s, &laser, MAX_GAP_S);
    (relations.len(), errors.unwrap())
}

/// Checks `set`'s errors against the published `trans` (m) and `rot` (°) mean ± std,
/// rounded as printed.
fn check(set: &str, trans: [&str; 2], rot: [&str; 2]) {
    let (relations, e) = raw_odometry_errors(set);
    println!("{set}: {e:?}");
    assert_eq!(
        e.count, relations,
        "{set}: every relation has poses near its times"
    );
    let got_trans = [
        format!("{:.3}", e.trans_mean_m),
        format!("{:.3}", e.trans_std_m),
    ];
    let got_rot = [
        format!("{:.2}", e.rot_mean_deg),
        format!("{:.2}", e.rot_std_deg),
    ];
    assert_eq!(got_trans, trans, "{set}: translational error (m)");
    assert_eq!(got_rot, rot, "{set}: rotational error (°)");
}

#[test]
fn relations_intel_raw_odometry_scores_as_published() {
    check("intel", ["7.370", "14.352"], ["39.17", "53.80"]);
}

#[test]
fn relations_aces_raw_odometry_scores_as_published() {
    check("aces", ["0.549", "2.675"], ["2.33", "6.51"]);
}

#[test]
fn relations_mit_csail_raw_odometry_scores_as_published() {
    check("mit-csail", ["1.681", "5.294"], ["5.07", "8.24"]);
}
