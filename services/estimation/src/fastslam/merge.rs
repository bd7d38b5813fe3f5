//! Landmark merging under unknown association (docs/ALGORITHMS.md §1 step 4): when a
//! re-sighting was taken for a new landmark, the particle holds two Gaussians for one
//! point. Once updates bring them together, they are fused into one.
//!
//! Only the landmarks a scan touched are tested, each against the others of its
//! particle within `search_radius`: the cost is that of one more association query per
//! touched landmark.

use super::landmarks::{Landmark, LandmarkMap};
use nalgebra::Vector2;

/// Merges each landmark of `touched` (ids) with the one of `map` it matches best, if
/// their Mahalanobis distance `(μ₁ − μ₂)ᵀ (Σ₁ + Σ₂)⁻¹ (μ₁ − μ₂)` is below `gate`; looks
/// within `radius` metres. The fused landmark keeps the older (smaller) id and the sum
/// of the hits. Returns how many landmarks merging removed.
pub(crate) fn merge_touched(
    map: &mut LandmarkMap,
    touched: &[u64],
    gate: f64,
    radius: f64,
) -> usize {
    let mut removed = 0;
    for &id in touched {
        let Some(a) = map.get(id).copied() else {
            continue; // merged into an earlier one of this scan
        };
        let best = map
            .within(a.mean, radius)
            .filter(|(slot, _)| slot.id() != id)
            .filter_map(|(_, b)| Some((mahalanobis_squared(&a, b)?, *b)))
            .filter(|(d2, _)| *d2 < gate)
            .min_by(|(d1, _), (d2, _)| d1.total_cmp(d2));
        if let Some((_, b)) = best
            && let Some(fused) = fuse(&a, &b)
        {
            map.remove(a.id);
            map.remove(b.id);
            map.insert(fused);
            removed += 1;
        }
    }
    removed
}

/// Keeps, of every group of landmarks of `map` that match within `gate` (looked for
/// within `radius` metres), the best supported one: landmarks are taken by hits (most
/// first, then the older id), and each removes the others that match it.
pub(crate) fn keep_best_supported(map: &mut LandmarkMap, gate: f64, radius: f64) {
    let mut order: Vec<Landmark> = map.iter().copied().collect();
    order.sort_by(|a, b| b.hits.cmp(&a.hits).then(a.id.cmp(&b.id)));
    for a in order {
        if map.get(a.id).is_none() {
            continue; // removed by a better supported one
        }
        let shadowed: Vec<u64> = (map.within(a.mean, radius))
            .filter(|(slot, _)| slot.id() != a.id)
            .filter(|(_, b)| mahalanobis_squared(&a, b).is_some_and(|d2| d2 < gate))
            .map(|(slot, _)| slot.id())
            .collect();
        for id in shadowed {
            map.remove(id);
        }
    }
}

/// `(μa − μb)ᵀ (Σa + Σb)⁻¹ (μa − μb)`; `None` if the sum is singular.
fn mahalanobis_squared(a: &Landmark, b: &Landmark) -> Option<f64> {
    let d: Vector2<f64> = a.mean - b.mean;
    let s = (a.covariance + b.covariance).try_inverse()?;
    Some(d.dot(&(s * d)))
}

/// The product of the two Gaussians (information form): two independent estimates of
/// one point. `None` if a covariance is singular.
fn fuse(a: &Landmark, b: &Landmark) -> Option<Landmark> {
    let (ia, ib) = (a.covariance.try_inverse()?, b.covariance.try_inverse()?);
    let covariance = (ia + ib).try_inverse()?;
    let covariance = (covariance + covariance.transpose()) / 2.0;
    let mean = covariance * (ia * a.mean + ib * b.mean);
    Some(Landmark {
        id: a.id.min(b.id),
        mean,
        covariance,
        hits: a.hits.saturating_add(b.hits),
        chances: a.chances.min(b.chances),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix2;

    fn landmark(id: u64, x: f64, y: f64, variance: f64) -> Landmark {
        Landmark {
            id,
            mean: Vector2::new(x, y),
            covariance: Matrix2::identity() * variance,
            hits: 2,
            chances: 0,
        }
    }

    #[test]
    fn two_gaussians_of_one_point_fuse_and_distinct_ones_stay() {
        let mut map = LandmarkMap::new(10.0);
        map.insert(landmark(3, 0.0, 0.0, 0.04));
        map.insert(landmark(7, 0.1, 0.0, 0.04)); // d² = 0.01 / 0.08 = 0.125
        map.insert(landmark(9, 2.0, 0.0, 0.04)); // d² = 50 from either
        assert_eq!(merge_touched(&mut map, &[7, 9], 9.21, 5.0), 1);
        assert_eq!(map.len(), 2);
        let fused = map.get(3).expect("the older id stays");
        assert!((fused.mean - Vector2::new(0.05, 0.0)).norm() < 1e-12);
        assert!((fused.covariance[(0, 0)] - 0.02).abs() < 1e-12);
        assert_eq!(fused.hits, 4);
        assert!(map.get(7).is_none() && map.get(9).is_some());
    }

    #[test]
    fn a_gate_of_zero_merges_nothing() {
        let mut map = LandmarkMap::new(10.0);
        map.insert(landmark(1, 0.0, 0.0, 0.04));
        map.insert(landmark(2, 0.0, 0.0, 0.04));
        assert_eq!(merge_touched(&mut map, &[1, 2], 0.0, 5.0), 0);
        assert_eq!(map.len(), 2);
    }
}
