//! What a [`FastSlam`] gives out between steps: the particle that weighed most, the
//! weighted cloud, the published map and the best particle's keyed sightings.

use super::*;

impl FastSlam {
    /// The particle that weighed most at the last step (before resampling, which leaves
    /// every copy the same weight): the one whose map and trajectory are published.
    pub fn best(&self) -> &Particle {
        &self.particles[self.best]
    }

    /// The particles as they are now, weighted: each particle's pose, or its motion prior
    /// `N(x̂, P)` with deferred sampling (where a drawn particle's prior is its pose with
    /// the floor covariance). After an update this is the cloud after resampling; the
    /// step's published estimate was taken before it.
    ///
    /// # Performance
    /// O(N).
    pub fn estimate(&self) -> PoseEstimate {
        let zero = Matrix3::zeros();
        let components = self.particles.iter().map(|p| {
            if self.deferred {
                (p.prior.mean, p.prior.covariance)
            } else {
                (p.pose, zero)
            }
        });
        PoseEstimate::from_mixture(components, self.weights.as_slice())
    }

    /// Step 7: the map of the particle that weighed most at the last step
    /// ([`best`](Self::best)), ordered by id, without its provisional landmarks (see
    /// [`is_confirmed`](Self::is_confirmed)).
    ///
    /// # Performance
    /// O(M log M) (collect and sort).
    pub fn best_map(&self) -> Vec<MapLandmark> {
        let best = self.best();
        let confirmed = best.map.iter().filter(|l| self.is_confirmed(l));
        let association = &self.config.association;
        let gate = association.map_merge_gate;
        let mut landmarks: Vec<MapLandmark> =
            if gate > 0.0 && association.mode == AssociationMode::Unknown {
                let mut shown = LandmarkMap::new(association.cell_size);
                confirmed.for_each(|l| shown.insert(*l));
                merge::keep_best_supported(&mut shown, gate, association.search_radius);
                shown.iter().map(MapLandmark::from).collect()
            } else {
                confirmed.map(MapLandmark::from).collect()
            };
        landmarks.sort_unstable_by_key(|l| l.id);
        landmarks
    }

    /// True when `landmark` has earned its place in the published map: under unknown
    /// association with negative evidence, once it was seen in `min_hits` scans; a
    /// provisional landmark is used by its particle but not published (it may still be
    /// removed, docs/ALGORITHMS.md §1 step 4).
    pub fn is_confirmed(&self, landmark: &Landmark) -> bool {
        landmark.hits >= self.config.negative_evidence_in_effect().min_hits
    }

    /// Landmarks in the published map ([`best_map`](Self::best_map)), counted without
    /// collecting them.
    pub fn confirmed_landmarks(&self) -> usize {
        if self.config.association.map_merge_gate > 0.0 {
            return self.best_map().len();
        }
        self.best()
            .map
            .iter()
            .filter(|l| self.is_confirmed(l))
            .count()
    }

    /// The last scan's accepted observations as the best particle explains them now:
    /// each with `id` set to the landmark of the best particle's map it is associated
    /// with (the one it updated or created), those it ignores left out. Taken by
    /// `sensor` (the last update's). The keyed sightings of the smoothing back-end
    /// (`graph::Smoother`), which works with unknown association too.
    ///
    /// # Performance
    /// One association of the scan against one map.
    pub fn best_sightings(&self, sensor: &Sensor) -> Vec<Observation> {
        let best = self.best();
        let association = &self.config.association;
        let accepted = &self.scratch.accepted;
        let scan = Scan::new(accepted, sensor, association, self.step);
        let decisions = scan.associate(&best.map, &best.pose).decisions;
        (accepted.iter().zip(decisions))
            .filter_map(|(obs, decision)| {
                let id = match decision {
                    Decision::Update { slot, .. } => slot.id(),
                    Decision::New { id: Some(id) } => id,
                    Decision::New { id: None } | Decision::Ignore => return None,
                };
                Some(Observation {
                    id: Some(id),
                    ..*obs
                })
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_published_map_shows_a_duplicate_once_and_the_particle_keeps_both() {
        let seen = Observation {
            range: 5.0,
            bearing: 0.1,
            id: None,
        };
        let far = Observation {
            range: 8.0,
            bearing: -1.0,
            id: None,
        };
        let mut config = FastSlamConfig {
            particles: 5,
            ..FastSlamConfig::default()
        };
        config.association.map_merge_gate = 9.21;
        let mut slam = FastSlam::new(config, Pose2::default()).unwrap();
        // Two scans, each detecting one point twice and another once: the particle holds
        // three landmarks, all confirmed (seen twice).
        slam.update(&[seen, seen, far]).unwrap();
        slam.update(&[seen, seen, far]).unwrap();
        assert_eq!(slam.best().map.len(), 3);
        let shown = slam.best_map();
        assert_eq!(shown.len(), 2, "{shown:?}");
        assert_eq!(slam.confirmed_landmarks(), 2);
        assert_eq!(slam.best().map.len(), 3, "the filter keeps its hypotheses");
    }
}
