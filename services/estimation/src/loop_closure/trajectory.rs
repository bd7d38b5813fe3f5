//! Every scan's pose from the optimised keyframes (docs/ALGORITHMS.md §9.1, "Trajectory").
//!
//! A scan between keyframes `k` and `k + 1` can be placed from either: keyframe `k`'s
//! optimised pose moved forward by the odometry since it, or keyframe `k + 1`'s moved back
//! by the odometry to it (to keyframe `k + 1`'s scan as the odometry put it, before that
//! scan was matched). The two differ by the correction the back-end made to the odometry
//! between the keyframes, the front end's scan match included. The odometry's noise is a
//! random walk along the path, so the most probable path given both ends carries each part
//! of that correction in proportion to the noise variance accumulated along it: the scan
//! takes the share of the correction that the variance up to it holds of the variance over
//! the whole stretch, for position and heading apart. Scans after the newest optimised
//! keyframe have no later end and keep the forward placement.

use crate::pose::{Pose2, wrap_angle};

/// Every scan's pose in the map frame.
///
/// - `scans`: in time order, each scan's front-end pose and the index of its keyframe
///   (the newest at or before it; a keyframe's own scan has its keyframe's pose);
/// - `front_end`: the front end's pose at each keyframe;
/// - `predicted`: the front end's pose at each keyframe before its scan was matched (the
///   odometry's end of the stretch from the keyframe before);
/// - `optimised`: the optimised poses of the first `optimised.len()` keyframes;
/// - `correction`: the map → front-end correction, for scans of keyframes not optimised;
/// - `variances`: the motion model's translation and heading variances of a motion
///   ([`crate::motion::MotionModel::path_variances`]).
pub fn place_scans(
    scans: &[(Pose2, usize)],
    front_end: &[Pose2],
    predicted: &[Pose2],
    optimised: &[Pose2],
    correction: &Pose2,
    variances: impl Fn(&Pose2) -> [f64; 2],
) -> Vec<Pose2> {
    let mut placed = Vec::with_capacity(scans.len());
    for group in scans.chunk_by(|a, b| a.1 == b.1) {
        let k = group[0].1;
        let Some(start) = optimised.get(k) else {
            placed.extend(group.iter().map(|(pose, _)| correction.compose(pose)));
            continue;
        };
        let from = front_end[k].inverse();
        let forward = group
            .iter()
            .map(|(pose, _)| start.compose(&from.compose(pose)));
        let (Some(end), Some(next)) = (optimised.get(k + 1), predicted.get(k + 1)) else {
            placed.extend(forward);
            continue;
        };
        let shares = shares_along(front_end[k], group, *next, &variances);
        let to = next.inverse();
        for ((forward, (pose, _)), share) in forward.zip(group).zip(shares) {
            let backward = end.compose(&to.compose(pose));
            placed.push(blend(&forward, &backward, share));
        }
    }
    placed
}

/// For each scan of `group`, the share of the path's noise variance from `first` (the
/// keyframe) up to the scan, of that up to `last` (the next keyframe as the odometry put
/// it): `[position, heading]`,
/// each in [0, 1] (0 where the path adds no variance).
fn shares_along(
    first: Pose2,
    group: &[(Pose2, usize)],
    last: Pose2,
    variances: &impl Fn(&Pose2) -> [f64; 2],
) -> Vec<[f64; 2]> {
    let mut previous = first;
    let mut accumulated = [0.0; 2];
    let mut upto = Vec::with_capacity(group.len());
    for (pose, _) in group {
        let step = variances(&previous.inverse().compose(pose));
        accumulated = [accumulated[0] + step[0], accumulated[1] + step[1]];
        upto.push(accumulated);
        previous = *pose;
    }
    let step = variances(&previous.inverse().compose(&last));
    let total = [accumulated[0] + step[0], accumulated[1] + step[1]];
    let share = |part: f64, whole: f64| if whole > 0.0 { part / whole } else { 0.0 };
    (upto.into_iter())
        .map(|[xy, theta]| [share(xy, total[0]), share(theta, total[1])])
        .collect()
}

/// `a` moved toward `b` by `share` (position, heading) of the way, in the map frame.
fn blend(a: &Pose2, b: &Pose2, share: [f64; 2]) -> Pose2 {
    let [xy, theta] = share;
    Pose2::new(
        a.x + xy * (b.x - a.x),
        a.y + xy * (b.y - a.y),
        wrap_angle(a.theta + theta * wrap_angle(b.theta - a.theta)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Variance proportional to the distance, for position and heading alike.
    fn by_distance(delta: &Pose2) -> [f64; 2] {
        let d = delta.x.hypot(delta.y);
        [d, d]
    }

    #[test]
    fn a_scan_takes_the_correction_in_proportion_to_the_path_before_it() {
        // The odometry drove 1 m along x in four 0.25 m scans; the front end matched the
        // second keyframe 5 cm to the left of that, and the back-end put it 0.1 m to the
        // left, turned by 0.04 rad.
        let front_end = [Pose2::new(0.0, 0.0, 0.0), Pose2::new(1.0, 0.05, 0.0)];
        let predicted = [front_end[0], Pose2::new(1.0, 0.0, 0.0)];
        let optimised = [Pose2::new(0.0, 0.0, 0.0), Pose2::new(1.0, 0.1, 0.04)];
        let scans: Vec<(Pose2, usize)> = (0..4)
            .map(|i| (Pose2::new(0.25 * i as f64, 0.0, 0.0), 0))
            .chain([(front_end[1], 1)])
            .collect();
        let placed = place_scans(
            &scans,
            &front_end,
            &predicted,
            &optimised,
            &Pose2::default(),
            by_distance,
        );
        assert_eq!(placed[0], optimised[0]);
        assert_eq!(placed[4], optimised[1]);
        for (i, pose) in placed.iter().enumerate().take(4) {
            let (along, share) = (0.25 * i as f64, 0.25 * i as f64);
            // Back from the second keyframe along the odometry: (1, 0.1, 0.04) ∘ (along − 1, 0, 0).
            let back = optimised[1].compose(&Pose2::new(along - 1.0, 0.0, 0.0));
            assert!((pose.x - share * back.x - (1.0 - share) * along).abs() < 1e-12);
            assert!((pose.y - share * back.y).abs() < 1e-12, "{i}: {pose:?}");
            assert!((pose.theta - share * 0.04).abs() < 1e-12, "{i}: {pose:?}");
        }
    }

    #[test]
    fn scans_beyond_the_optimised_keyframes_keep_their_forward_or_corrected_placement() {
        let front_end = [Pose2::new(0.0, 0.0, 0.0), Pose2::new(1.0, 0.0, 0.0)];
        let optimised = [Pose2::new(0.5, 0.0, 0.1)];
        let correction = Pose2::new(0.0, 2.0, 0.0);
        let scans = [
            (Pose2::new(0.0, 0.0, 0.0), 0),
            (Pose2::new(0.5, 0.0, 0.0), 0),
            (Pose2::new(1.0, 0.0, 0.0), 1),
        ];
        let placed = place_scans(
            &scans,
            &front_end,
            &front_end,
            &optimised,
            &correction,
            by_distance,
        );
        assert_eq!(placed[1], optimised[0].compose(&Pose2::new(0.5, 0.0, 0.0)));
        assert_eq!(placed[2], correction.compose(&scans[2].0));
    }

    #[test]
    fn no_motion_between_keyframes_keeps_the_forward_placement() {
        let front_end = [Pose2::new(0.0, 0.0, 0.0), Pose2::new(0.0, 0.0, 0.0)];
        let optimised = [Pose2::new(0.0, 0.0, 0.0), Pose2::new(0.0, 0.2, 0.0)];
        let scans = [(front_end[0], 0), (front_end[0], 0), (front_end[1], 1)];
        let placed = place_scans(
            &scans,
            &front_end,
            &front_end,
            &optimised,
            &Pose2::default(),
            by_distance,
        );
        assert_eq!(placed[1], optimised[0]);
        assert_eq!(placed[2], optimised[1]);
    }
}
