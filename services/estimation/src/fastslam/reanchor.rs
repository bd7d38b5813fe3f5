//! Re-anchoring a [`FastSlam`] onto a smoothed solution (docs/ALGORITHMS.md §8.1).

use super::*;

impl FastSlam {
    /// Moves every particle onto a smoothed solution (re-anchoring, docs/ALGORITHMS.md
    /// §8.1): each pose, motion prior and landmark by the rigid `correction` (applied on
    /// the left: world → corrected world), then the landmarks the solution has (`(id,
    /// position, covariance)`, in the corrected world) set to the solution's values.
    ///
    /// # Performance
    /// O(N · M log M): every landmark of every particle is touched (shared maps are
    /// copied where they change).
    pub fn reanchor(
        &mut self,
        correction: &Pose2,
        landmarks: &[(u64, Vector2<f64>, Matrix2<f64>)],
    ) {
        let solved: std::collections::HashMap<u64, (Vector2<f64>, Matrix2<f64>)> =
            landmarks.iter().map(|&(id, m, c)| (id, (m, c))).collect();
        let (s, c) = correction.theta.sin_cos();
        let rotation = Matrix2::new(c, -s, s, c);
        let rotation3 = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
        let moved = |p: &Vector2<f64>| {
            let q = correction.compose(&Pose2::new(p.x, p.y, 0.0));
            Vector2::new(q.x, q.y)
        };
        self.check_prior.mean = correction.compose(&self.check_prior.mean);
        self.check_prior.covariance =
            rotation3 * self.check_prior.covariance * rotation3.transpose();
        for particle in &mut self.particles {
            particle.pose = correction.compose(&particle.pose);
            particle.prior.mean = correction.compose(&particle.prior.mean);
            particle.prior.covariance =
                rotation3 * particle.prior.covariance * rotation3.transpose();

            let ids: Vec<u64> = particle.map.iter().map(|l| l.id).collect();
            for id in ids {
                particle.map.update(id, |l| match solved.get(&id) {
                    Some(&(mean, covariance)) => (l.mean, l.covariance) = (mean, covariance),
                    None => {
                        l.mean = moved(&l.mean);
                        l.covariance = rotation * l.covariance * rotation.transpose();
                    }
                });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reanchoring_moves_poses_and_maps_and_takes_the_solved_landmarks() {
        let config = FastSlamConfig {
            particles: 5,
            ..FastSlamConfig::default()
        };
        let mut slam = FastSlam::new(config, Pose2::new(1.0, 0.0, 0.0)).unwrap();
        let seen = [
            Observation {
                range: 10.0,
                bearing: 0.0,
                id: None,
            },
            Observation {
                range: 5.0,
                bearing: std::f64::consts::FRAC_PI_2,
                id: None,
            },
        ];
        slam.update(&seen).unwrap();
        assert!(slam.best_map().is_empty(), "provisional after one sighting");
        slam.update(&seen).unwrap();
        let before = slam.best_map();
        assert_eq!(before.len(), 2, "confirmed by the second");
        // A quarter turn about the origin, then 2 m along x; the first landmark solved.
        let correction = Pose2::new(2.0, 0.0, std::f64::consts::FRAC_PI_2);
        let solved = (
            before[0].id,
            Vector2::new(-7.0, 3.0),
            Matrix2::identity() * 0.5,
        );
        slam.reanchor(&correction, &[solved]);
        for p in slam.particles() {
            assert!((p.pose.x - 2.0).abs() < 1e-9 && (p.pose.y - 1.0).abs() < 1e-9);
            assert!((p.pose.theta - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
        }
        let after = slam.best_map();
        assert_eq!((after[0].mean, after[0].covariance), (solved.1, solved.2));
        let moved = correction.compose(&Pose2::new(before[1].mean.x, before[1].mean.y, 0.0));
        assert!((after[1].mean - Vector2::new(moved.x, moved.y)).norm() < 1e-9);
        // The covariance turns with the map: xx and yy swap under a quarter turn.
        let (b, a) = (before[1].covariance, after[1].covariance);
        assert!((a[(0, 0)] - b[(1, 1)]).abs() < 1e-12 && (a[(1, 1)] - b[(0, 0)]).abs() < 1e-12);
    }
}
