//! Where a solve's map frame is put (docs/ALGORITHMS.md §9.1, "The map frame's gauge").
//!
//! A pose graph fixes its keyframes only up to one rigid motion of them all; the graph's
//! prior on the first keyframe picks one. A real-time pose published in that frame moves
//! wherever the solve moves the places around the robot, including the places it
//! published poses in before. [`local_gauge`] picks the rigid motion instead so that the
//! keyframes near the robot land, as well as one rigid motion can put them, where their
//! poses were published: a robot coming back to a place is published where it was
//! published the first time, up to what the loop closures there correct.

use crate::Pose2;

/// The rigid motion `G` that takes the solve's keyframe poses `solved` nearest the
/// newest of them onto the poses `published` for them when each was the robot's, each
/// keyframe weighted by `exp(−d² / 2r²)`, `d` its distance from the newest keyframe in
/// the solve and `r` = `radius` (m). `G`'s rotation is the weighted circular mean of the
/// heading differences, its translation the weighted mean of `published − R solved`:
/// the weighted least squares of both. Keyframes without a published pose (`published`
/// is shorter) take no part. `None` when `radius` is not positive or no keyframe weighs
/// more than 10⁻⁶.
///
/// # Performance
/// O(keyframes), one pass.
pub fn local_gauge(solved: &[Pose2], published: &[Pose2], radius: f64) -> Option<Pose2> {
    let newest = solved.last()?;
    if radius.is_nan() || radius <= 0.0 {
        return None;
    }
    let weights: Vec<(f64, &Pose2, &Pose2)> = (solved.iter().zip(published))
        .filter_map(|(x, p)| {
            let d2 = (x.x - newest.x).powi(2) + (x.y - newest.y).powi(2);
            let w = (-0.5 * d2 / (radius * radius)).exp();
            (w > 1e-6).then_some((w, x, p))
        })
        .collect();
    let total: f64 = weights.iter().map(|(w, _, _)| w).sum();
    if total <= 0.0 {
        return None;
    }
    let (sin, cos) = weights.iter().fold((0.0, 0.0), |(s, c), (w, x, p)| {
        let turn = p.theta - x.theta;
        (s + w * turn.sin(), c + w * turn.cos())
    });
    let phi = sin.atan2(cos);
    let rotation = Pose2::new(0.0, 0.0, phi);
    let (tx, ty) = weights.iter().fold((0.0, 0.0), |(tx, ty), (w, x, p)| {
        let [rx, ry] = rotation.transform_point([x.x, x.y]);
        (tx + w * (p.x - rx), ty + w * (p.y - ry))
    });
    Some(Pose2::new(tx / total, ty / total, phi))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Keyframes every 0.5 m along a 20 m straight line, then back along it.
    fn there_and_back() -> Vec<Pose2> {
        let out = (0..40).map(|i| Pose2::new(0.5 * f64::from(i), 0.0, 0.0));
        let back = (0..40).map(|i| Pose2::new(19.5 - 0.5 * f64::from(i), 0.3, 3.1));
        out.chain(back).collect()
    }

    fn close(a: &Pose2, b: &Pose2) -> bool {
        (a.x - b.x).abs() < 1e-9 && (a.y - b.y).abs() < 1e-9 && (a.theta - b.theta).abs() < 1e-9
    }

    #[test]
    fn poses_published_in_a_moved_frame_give_that_motion() {
        let solved = there_and_back();
        let moved = Pose2::new(1.5, -2.0, 0.4);
        let published: Vec<Pose2> = solved.iter().map(|x| moved.compose(x)).collect();
        let gauge = local_gauge(&solved, &published, 3.0).unwrap();
        assert!(close(&gauge, &moved), "{gauge:?}");
        // Keyframes not published yet take no part.
        let gauge = local_gauge(&solved, &published[..60], 3.0).unwrap();
        assert!(close(&gauge, &moved), "{gauge:?}");
    }

    #[test]
    fn the_places_near_the_robot_decide_and_far_ones_do_not() {
        let solved = there_and_back();
        // The robot is back at the start: the first keyframes were published 1 m and 2°
        // off from where this solve puts them, the far end 5 m and 30° off.
        let near = Pose2::new(1.0, 0.0, 2f64.to_radians());
        let far = Pose2::new(5.0, 0.0, 30f64.to_radians());
        let published: Vec<Pose2> = (solved.iter())
            .map(|x| if x.x < 12.0 { near } else { far }.compose(x))
            .collect();
        let gauge = local_gauge(&solved, &published, 3.0).unwrap();
        assert!(
            (gauge.x - near.x).abs() < 5e-3
                && gauge.y.abs() < 5e-3
                && (gauge.theta - near.theta).abs() < 1e-3,
            "{gauge:?}"
        );
    }

    #[test]
    fn no_radius_or_no_keyframe_leaves_the_gauge_to_the_caller() {
        let solved = there_and_back();
        assert_eq!(local_gauge(&solved, &solved, 0.0), None);
        assert_eq!(local_gauge(&solved, &solved, f64::NAN), None);
        assert_eq!(local_gauge(&[], &[], 3.0), None);
        assert_eq!(local_gauge(&solved, &[], 3.0), None);
    }
}
