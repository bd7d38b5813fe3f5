//! Loop closure in the graph under unknown association (docs/ALGORITHMS.md §8.2): finding
//! the landmarks the filter mapped twice — a landmark seen again after the path drifted
//! gets a new id, since every particle drifted alike — and fusing them, so that the graph
//! closes the loop the filter left open.
//!
//! Two landmarks `a` and `b` are *compatible* when
//! - no pose saw both (a scan never sees one landmark twice), and
//! - their difference is compatible with zero at the solution:
//!   `d² = Δᵀ S⁻¹ Δ ≤ gate`, `Δ = m_a − m_b`, `S = P_a + P_b − C_ab − C_abᵀ` the
//!   covariance of `Δ` (marginals and cross-covariance, blocks of `H⁻¹`).
//!
//! Compatible landmarks form groups (connected components). A group is one landmark only
//! when every two of its members are compatible: three sightings of one landmark fuse,
//! while a landmark that could be either of two distinct ones fuses with neither — it
//! waits until a fused neighbour has shrunk the marginals enough to tell.

use super::{Graph, Kernel};
use crate::Result;
use nalgebra::Matrix2;
use std::collections::{BTreeMap, HashSet};

/// Groups of landmarks (indices, ascending) that the solution says are one landmark each;
/// see the module documentation. `gate` is the `d²` threshold (a χ²₂ quantile); the pairs
/// in `refused` (`(a, b)`, `a < b`) are taken as incompatible.
///
/// # Errors
/// When the graph's information cannot be factorised (as [`Graph::covariances`]).
///
/// # Performance
/// One factorisation of the graph's information, O(M²) for a map of M landmarks (a 2 × 2
/// test per pair), and one covariance block per candidate pair.
pub fn duplicates(
    graph: &Graph,
    kernel: Kernel,
    gate: f64,
    refused: &HashSet<(usize, usize)>,
) -> Result<Vec<Vec<usize>>> {
    let m = graph.landmarks.len();
    let covariances = graph.covariances(kernel)?;
    let marginals = covariances.marginals()?;
    let covisible = covisible(graph);
    // The cross-covariance of two landmarks seen along one drifting path is mostly
    // positive, which makes `S` smaller than `P_a + P_b`: a looser first test keeps
    // every pair the exact one could accept.
    let loose = |a: usize, b: usize| {
        let d = graph.landmarks[a] - graph.landmarks[b];
        mahalanobis(&d, &(marginals[a] + marginals[b])).is_some_and(|d2| d2 <= 4.0 * gate)
    };
    let candidates: Vec<(usize, usize)> = (0..m)
        .flat_map(|a| (a + 1..m).map(move |b| (a, b)))
        .filter(|pair| !covisible.contains(pair) && !refused.contains(pair))
        .filter(|&(a, b)| loose(a, b))
        .collect();
    let cross = covariances.blocks(&candidates)?;
    let compatible: HashSet<(usize, usize)> = (candidates.iter().zip(&cross))
        .filter(|&(&(a, b), c)| {
            let d = graph.landmarks[a] - graph.landmarks[b];
            let s = marginals[a] + marginals[b] - c - c.transpose();
            mahalanobis(&d, &s).is_some_and(|d2| d2 <= gate)
        })
        .map(|(&pair, _)| pair)
        .collect();

    let mut groups = Components::new(m);
    for &(a, b) in &compatible {
        groups.join(a, b);
    }
    Ok(groups
        .into_groups()
        .into_iter()
        .filter(|g| {
            g.len() > 1
                && (g.iter().enumerate())
                    .all(|(i, &a)| g[i + 1..].iter().all(|&b| compatible.contains(&(a, b))))
        })
        .collect())
}

impl Graph {
    /// Fuses each group of landmarks into its first: the others' sightings and offsets
    /// name the first, and the others are removed (the first keeps its estimate).
    /// Returns, for every landmark index before, its index after (a fused one's is its
    /// group's first).
    ///
    /// # Panics
    /// When a group names a landmark the graph does not have, or one twice.
    pub fn fuse_landmarks(&mut self, groups: &[Vec<usize>]) -> Vec<usize> {
        let mut into: Vec<usize> = (0..self.landmarks.len()).collect();
        for group in groups {
            for &k in &group[1..] {
                assert_ne!(k, group[0], "a landmark fused into itself");
                into[k] = group[0];
            }
        }
        let mut renumbered = vec![usize::MAX; into.len()];
        let mut kept = 0;
        for k in 0..into.len() {
            if into[k] == k {
                renumbered[k] = kept;
                self.landmarks[kept] = self.landmarks[k];
                kept += 1;
            }
        }
        self.landmarks.truncate(kept);
        let after: Vec<usize> = into.iter().map(|&k| renumbered[k]).collect();
        for s in &mut self.sightings {
            s.landmark = after[s.landmark];
        }
        for o in &mut self.offsets {
            o.landmark = after[o.landmark];
        }
        after
    }
}

/// `dᵀ S⁻¹ d`, `None` when `S` is not positive definite.
fn mahalanobis(d: &nalgebra::Vector2<f64>, s: &Matrix2<f64>) -> Option<f64> {
    let cholesky = s.cholesky()?;
    let d2 = d.dot(&cholesky.solve(d));
    d2.is_finite().then_some(d2)
}

/// Pairs `(a, b)`, `a < b`, of landmarks that one pose saw both of.
fn covisible(graph: &Graph) -> HashSet<(usize, usize)> {
    let mut by_pose: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    let seen = (graph.sightings.iter().map(|s| (s.pose, s.landmark)))
        .chain(graph.offsets.iter().map(|o| (o.pose, o.landmark)));
    for (pose, landmark) in seen {
        by_pose.entry(pose).or_default().push(landmark);
    }
    let mut pairs = HashSet::new();
    for seen in by_pose.values() {
        for (i, &a) in seen.iter().enumerate() {
            for &b in &seen[i + 1..] {
                pairs.insert((a.min(b), a.max(b)));
            }
        }
    }
    pairs
}

/// Connected components over `0..n` (union–find with path halving).
struct Components {
    parent: Vec<usize>,
}

impl Components {
    fn new(n: usize) -> Self {
        Self {
            parent: (0..n).collect(),
        }
    }

    fn root(&mut self, mut k: usize) -> usize {
        while self.parent[k] != k {
            self.parent[k] = self.parent[self.parent[k]];
            k = self.parent[k];
        }
        k
    }

    fn join(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.root(a), self.root(b));
        self.parent[ra.max(rb)] = ra.min(rb);
    }

    /// The components, each ascending, ordered by their first member.
    fn into_groups(mut self) -> Vec<Vec<usize>> {
        let mut groups: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
        for k in 0..self.parent.len() {
            let root = self.root(k);
            groups.entry(root).or_default().push(k);
        }
        groups.into_values().collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observation::Observation;
    use crate::pose::Pose2;
    use nalgebra::Vector2;

    #[test]
    fn fusing_renumbers_the_landmarks_and_their_sightings() {
        let mut graph = Graph::default();
        graph.add_pose(Pose2::default());
        for k in 0..5 {
            graph.add_landmark(Vector2::new(f64::from(k) + 1.0, 0.0));
        }
        let obs = Observation {
            range: 1.0,
            bearing: 0.0,
            id: None,
        };
        for k in 0..5 {
            graph
                .add_sighting(0, k, &obs, &Matrix2::identity())
                .unwrap();
        }
        // 3 into 1, and 4 and 2 into 0.
        let after = graph.fuse_landmarks(&[vec![1, 3], vec![0, 2, 4]]);
        assert_eq!(after, vec![0, 1, 0, 1, 0]);
        assert_eq!(
            graph.landmarks,
            vec![Vector2::new(1.0, 0.0), Vector2::new(2.0, 0.0)]
        );
        let named: Vec<usize> = graph.sightings.iter().map(|s| s.landmark).collect();
        assert_eq!(named, vec![0, 1, 0, 1, 0]);
    }

    #[test]
    fn landmarks_one_pose_saw_together_are_never_fused() {
        // Two landmarks 1 cm apart, both seen from the one pose: distinct by definition.
        let mut graph = Graph::default();
        graph.add_pose(Pose2::default());
        graph.priors.push(super::super::Prior {
            pose: 0,
            mean: Pose2::default(),
            information: nalgebra::Matrix3::identity(),
        });
        for (k, bearing) in [0.0, 0.001].into_iter().enumerate() {
            let obs = Observation {
                range: 10.0,
                bearing,
                id: None,
            };
            graph.add_landmark(crate::observation::inverse(&Pose2::default(), &obs.z()).0);
            graph
                .add_sighting(0, k, &obs, &Matrix2::identity())
                .unwrap();
        }
        let none = HashSet::new();
        assert!(
            duplicates(&graph, Kernel::None, 9.21, &none)
                .unwrap()
                .is_empty()
        );
    }
}
