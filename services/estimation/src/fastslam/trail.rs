//! A particle's pose history, for building an occupancy grid from the particle's own
//! trajectory (the grid of the best particle stays consistent with its map, whichever
//! particle is best at the moment).
//!
//! The history is a persistent singly linked list: each node holds one pose and points to
//! the node before it, behind an `Arc`. A resampled copy shares its ancestor's whole
//! history, so resampling costs O(1) per particle, and the histories of N particles form
//! a tree whose shared trunk is stored once: memory is O(K + N·d) poses for K recorded
//! poses and particles that diverged d poses ago (the trunk coalesces quickly under
//! resampling), not O(N·K). Only poses at keyframes are recorded (see [`crate::grid`]).

use crate::pose::Pose2;
use std::sync::Arc;

/// One recorded pose and the history before it.
#[derive(Debug)]
struct Node {
    keyframe: u64,
    pose: Pose2,
    parent: Option<Arc<Node>>,
}

/// A particle's recorded poses, newest first; cloning shares the whole history.
#[derive(Debug, Clone, Default)]
pub struct Trail {
    head: Option<Arc<Node>>,
    len: usize,
}

impl Trail {
    /// Records the particle's `pose` at keyframe `keyframe` (keyframes increase).
    ///
    /// # Performance
    /// O(1): one allocation; the history before is shared, not copied.
    pub fn push(&mut self, keyframe: u64, pose: Pose2) {
        let parent = self.head.take();
        self.head = Some(Arc::new(Node {
            keyframe,
            pose,
            parent,
        }));
        self.len += 1;
    }

    /// Number of recorded poses.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when nothing was recorded.
    pub fn is_empty(&self) -> bool {
        self.head.is_none()
    }

    /// The recorded `(keyframe, pose)` pairs, newest first.
    pub fn iter(&self) -> impl Iterator<Item = (u64, Pose2)> + '_ {
        std::iter::successors(self.head.as_deref(), |n| n.parent.as_deref())
            .map(|n| (n.keyframe, n.pose))
    }

    /// The poses recorded after `earlier`, oldest first, when `earlier` is a prefix of
    /// this history (the same nodes, not equal values); `None` otherwise.
    ///
    /// # Performance
    /// O(number of poses after `earlier`).
    pub fn since(&self, earlier: &Trail) -> Option<Vec<(u64, Pose2)>> {
        let mut newer = Vec::new();
        let mut node = self.head.as_ref();
        loop {
            match (node, &earlier.head) {
                (Some(n), Some(e)) if Arc::ptr_eq(n, e) => break,
                (None, None) => break,
                (Some(n), _)
                    if earlier
                        .head
                        .as_ref()
                        .is_none_or(|e| n.keyframe > e.keyframe) =>
                {
                    newer.push((n.keyframe, n.pose));
                    node = n.parent.as_ref();
                }
                _ => return None,
            }
        }
        newer.reverse();
        Some(newer)
    }
}

impl Drop for Trail {
    /// Frees the nodes only this trail holds one by one: the default recursive drop of a
    /// long list would overflow the stack.
    fn drop(&mut self) {
        let mut next = self.head.take();
        while let Some(node) = next {
            match Arc::try_unwrap(node) {
                Ok(mut node) => next = node.parent.take(),
                Err(_) => break,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(x: f64) -> Pose2 {
        Pose2::new(x, 0.0, 0.0)
    }

    #[test]
    fn copies_share_history_and_since_finds_the_new_part() {
        let mut parent = Trail::default();
        (0..3).for_each(|k| parent.push(k, pose(k as f64)));
        let mut child = parent.clone();
        child.push(3, pose(3.0));
        child.push(4, pose(4.0));
        assert_eq!(child.len(), 5);
        let xs: Vec<f64> = child.iter().map(|(_, p)| p.x).collect();
        assert_eq!(xs, [4.0, 3.0, 2.0, 1.0, 0.0]);
        let new: Vec<u64> = child.since(&parent).unwrap().iter().map(|k| k.0).collect();
        assert_eq!(new, [3, 4]);
        assert_eq!(child.since(&Trail::default()).unwrap().len(), 5);
        assert_eq!(
            parent.since(&child),
            None,
            "the parent lacks the child's poses"
        );
        let mut cousin = parent.clone();
        cousin.push(3, pose(3.0));
        assert_eq!(
            child.since(&cousin),
            None,
            "equal values, other nodes: not a prefix"
        );
    }

    #[test]
    fn a_long_history_drops_without_overflowing_the_stack() {
        let mut trail = Trail::default();
        (0..1_000_000).for_each(|k| trail.push(k, pose(0.0)));
        let copy = trail.clone();
        drop(trail);
        assert_eq!(copy.len(), 1_000_000);
    }
}
