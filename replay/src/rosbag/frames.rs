//! Coordinate frames from a bag's tf topics: `/tf_static` (fixed transforms such as the
//! laser's mounting) and `/tf` (moving ones such as `odom → base_link`).
//!
//! tf publishes each frame's pose in its parent frame, so the frames form a tree. A
//! transform between any two frames chains the edges up from each to their nearest common
//! ancestor (`odom → base_footprint → base_link`, or `base_link → laser` through a mount
//! frame), in 3D, and is projected to the plane only at the end ([`Transform::pose2`]).
//! A moving edge is taken at the newest sample at or before the time asked for (its first
//! sample before that).

use fastslam_estimation::Pose2;
use std::collections::{BTreeMap, HashSet};

/// A rigid transform: the pose of a child frame in its parent frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    /// Translation (m).
    pub t: [f64; 3],
    /// Unit rotation quaternion `[x, y, z, w]`.
    pub q: [f64; 4],
}

impl Transform {
    /// No translation, no rotation.
    pub const IDENTITY: Self = Self {
        t: [0.0; 3],
        q: [0.0, 0.0, 0.0, 1.0],
    };

    /// A transform from a translation and a quaternion `[x, y, z, w]`, which is
    /// normalised.
    ///
    /// # Errors
    /// When a value is not finite or the quaternion has no length.
    pub fn new(t: [f64; 3], q: [f64; 4]) -> Result<Self, String> {
        let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !(t.iter().all(|v| v.is_finite()) && norm.is_finite()) {
            return Err(format!("transform {t:?} {q:?} is not finite"));
        }
        if norm < 1e-9 {
            return Err(format!("rotation {q:?} is not a quaternion (zero length)"));
        }
        Ok(Self {
            t,
            q: q.map(|v| v / norm),
        })
    }

    /// `v` rotated by this transform's rotation.
    pub fn rotate(&self, v: [f64; 3]) -> [f64; 3] {
        let [x, y, z, w] = self.q;
        let u = [x, y, z];
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let c1 = cross(u, v);
        let c2 = cross(u, c1);
        [0, 1, 2].map(|i| v[i] + 2.0 * (w * c1[i] + c2[i]))
    }

    /// `self` followed by `next`: with `self` the pose of frame B in A and `next` that of
    /// C in B, the pose of C in A.
    pub fn then(&self, next: &Self) -> Self {
        let r = self.rotate(next.t);
        let [ax, ay, az, aw] = self.q;
        let [bx, by, bz, bw] = next.q;
        Self {
            t: [0, 1, 2].map(|i| self.t[i] + r[i]),
            q: [
                aw * bx + ax * bw + ay * bz - az * by,
                aw * by - ax * bz + ay * bw + az * bx,
                aw * bz + ax * by - ay * bx + az * bw,
                aw * bw - ax * bx - ay * by - az * bz,
            ],
        }
    }

    /// The inverse: the parent's pose in the child frame.
    pub fn inverse(&self) -> Self {
        let [x, y, z, w] = self.q;
        let q = [-x, -y, -z, w];
        let rotation = Self { t: [0.0; 3], q };
        let r = rotation.rotate(self.t);
        Self {
            t: r.map(|v| -v),
            q,
        }
    }

    /// Heading of the child's x axis in the parent's plane (rad).
    pub fn yaw(&self) -> f64 {
        let [x, y, z, w] = self.q;
        (2.0 * (w * z + x * y)).atan2(w * w + x * x - y * y - z * z)
    }

    /// The planar pose: x, y and [`Self::yaw`].
    pub fn pose2(&self) -> Pose2 {
        Pose2::new(self.t[0], self.t[1], self.yaw())
    }

    /// The vertical component of the child's z axis: 1 when level, < 0 upside down.
    pub fn up(&self) -> f64 {
        let [x, y, _, _] = self.q;
        1.0 - 2.0 * (x * x + y * y)
    }

    /// The same frame turned half a turn about its own x axis (an upside-down laser's
    /// frame made upright: its beams then turn the other way).
    pub fn flipped(&self) -> Self {
        self.then(&Self {
            t: [0.0; 3],
            q: [1.0, 0.0, 0.0, 0.0],
        })
    }
}

/// One edge of the tree: a child frame's pose in its parent over time.
#[derive(Debug, Clone)]
struct Edge {
    parent: String,
    /// Only ever published on `/tf_static`.
    fixed: bool,
    /// `(stamp_ns, transform)`, sorted by stamp once [`TfTree::finish`] ran.
    samples: Vec<(u64, Transform)>,
}

impl Edge {
    /// The newest sample at or before `stamp_ns` (the first one before that).
    fn at(&self, stamp_ns: u64) -> Transform {
        let k = self.samples.partition_point(|(t, _)| *t <= stamp_ns);
        self.samples[k.saturating_sub(1)].1
    }
}

/// The frames seen on a bag's tf topics.
#[derive(Debug, Clone, Default)]
pub struct TfTree {
    /// Edges by child frame.
    edges: BTreeMap<String, Edge>,
    /// What was ignored (a frame given a second parent), for the bag's warnings.
    pub warnings: Vec<String>,
}

impl TfTree {
    /// Adds a transform of `child` in `parent` at `stamp_ns`; `fixed` when it comes from
    /// `/tf_static`, where the newest transform of a frame replaces the older ones.
    pub fn add(&mut self, parent: &str, child: &str, stamp_ns: u64, t: Transform, fixed: bool) {
        let edge = self.edges.entry(child.to_string()).or_insert_with(|| Edge {
            parent: parent.to_string(),
            fixed,
            samples: Vec::new(),
        });
        if edge.parent != parent {
            let warning = format!(
                "tf: frame `{child}` has parent `{}`; its transforms from `{parent}` are ignored",
                edge.parent
            );
            if !self.warnings.contains(&warning) {
                self.warnings.push(warning);
            }
            return;
        }
        if fixed && edge.fixed {
            edge.samples.clear();
        }
        edge.fixed &= fixed;
        edge.samples.push((stamp_ns, t));
    }

    /// Sorts every edge's samples by stamp; call once everything was added.
    pub fn finish(&mut self) {
        for edge in self.edges.values_mut() {
            edge.samples.sort_by_key(|(t, _)| *t);
        }
    }

    /// Whether no transform was added.
    pub fn is_empty(&self) -> bool {
        self.edges.is_empty()
    }

    /// Whether `frame` appears in the tree (as a parent or a child).
    pub fn has(&self, frame: &str) -> bool {
        self.edges.contains_key(frame) || self.edges.values().any(|e| e.parent == frame)
    }

    /// The frames whose parent is `parent`.
    pub fn children(&self, parent: &str) -> Vec<&str> {
        (self.edges.iter())
            .filter(|(_, e)| e.parent == parent)
            .map(|(c, _)| c.as_str())
            .collect()
    }

    /// `frame`, its parent, its parent's parent… up to the root.
    fn ancestors<'a>(&'a self, frame: &'a str) -> Vec<&'a str> {
        let mut out = vec![frame];
        let mut seen = HashSet::from([frame]);
        let mut at = frame;
        while let Some(edge) = self.edges.get(at) {
            if !seen.insert(edge.parent.as_str()) {
                break; // a loop in a corrupt tree
            }
            at = &edge.parent;
            out.push(at);
        }
        out
    }

    /// The edges from `from` to `to`: `(child, upward)` for each, where `upward` edges are
    /// walked from child to parent (inverted). `None` when the frames are not connected.
    fn path<'a>(&'a self, from: &'a str, to: &'a str) -> Option<Vec<(&'a str, bool)>> {
        let up = self.ancestors(from);
        let down = self.ancestors(to);
        let (i, j) = (up.iter().enumerate())
            .find_map(|(i, f)| down.iter().position(|d| d == f).map(|j| (i, j)))?;
        let mut steps: Vec<(&str, bool)> = up[..i].iter().map(|c| (*c, true)).collect();
        steps.extend(down[..j].iter().rev().map(|c| (*c, false)));
        Some(steps)
    }

    /// The pose of `to` in `from`, every moving edge taken at `stamp_ns`; `None` when the
    /// frames are not connected.
    pub fn lookup(&self, from: &str, to: &str, stamp_ns: u64) -> Option<Transform> {
        let steps = self.path(from, to)?;
        Some(
            steps
                .iter()
                .fold(Transform::IDENTITY, |acc, (child, upward)| {
                    let t = self.edges[*child].at(stamp_ns);
                    acc.then(&if *upward { t.inverse() } else { t })
                }),
        )
    }

    /// Whether every edge between the connected frames `from` and `to` is fixed
    /// (`/tf_static` only).
    pub fn is_fixed(&self, from: &str, to: &str) -> bool {
        (self.path(from, to).unwrap_or_default().iter()).all(|(c, _)| self.edges[*c].fixed)
    }

    /// The pose of `to` in `from` over time: one sample per stamp of the busiest moving
    /// edge between them (the other moving edges taken at that stamp). `None` when they
    /// are not connected or nothing between them moves.
    pub fn track(&self, from: &str, to: &str) -> Option<Vec<(u64, Transform)>> {
        let steps = self.path(from, to)?;
        let busiest = (steps.iter().map(|(c, _)| &self.edges[*c]))
            .filter(|e| !e.fixed)
            .fold(None::<&Edge>, |best, e| match best {
                Some(b) if b.samples.len() >= e.samples.len() => Some(b),
                _ => Some(e),
            })?;
        (busiest.samples.iter())
            .map(|(t, _)| Some((*t, self.lookup(from, to, *t)?)))
            .collect()
    }

    /// Every edge as `parent→child`, with its sample count or `static`, for error
    /// messages.
    pub fn listing(&self) -> String {
        if self.edges.is_empty() {
            return "no transforms".into();
        }
        (self.edges.iter())
            .map(|(child, e)| {
                let kind = if e.fixed {
                    "static".to_string()
                } else {
                    e.samples.len().to_string()
                };
                format!("{}→{child} ({kind})", e.parent)
            })
            .collect::<Vec<_>>()
            .join(", ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    fn planar(x: f64, y: f64, yaw: f64) -> Transform {
        Transform::new(
            [x, y, 0.0],
            [0.0, 0.0, (yaw / 2.0).sin(), (yaw / 2.0).cos()],
        )
        .unwrap()
    }

    fn close(a: Pose2, b: Pose2) -> bool {
        (a.x - b.x).abs() < 1e-12
            && (a.y - b.y).abs() < 1e-12
            && fastslam_estimation::wrap_angle(a.theta - b.theta).abs() < 1e-12
    }

    #[test]
    fn transforms_compose_and_invert() {
        let a = planar(1.0, 0.0, FRAC_PI_2);
        let b = planar(2.0, 0.0, 0.0);
        assert!(close(a.then(&b).pose2(), Pose2::new(1.0, 2.0, FRAC_PI_2)));
        assert!(close(a.then(&a.inverse()).pose2(), Pose2::default()));
        let tilted = Transform::new([0.0; 3], [0.0, 0.3, 0.0, 1.0]).unwrap();
        assert!(tilted.up() < 1.0 && tilted.up() > 0.0);
        assert!(Transform::new([0.0; 3], [0.0; 4]).is_err());
        assert!(Transform::new([f64::NAN, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]).is_err());
    }

    #[test]
    fn an_upside_down_frame_flips_upright() {
        // Yaw 0.3, then half a turn about x: beams at angle a point at 0.3 − a.
        let mount = planar(0.2, -0.1, 0.3).then(&Transform {
            t: [0.0; 3],
            q: [1.0, 0.0, 0.0, 0.0],
        });
        assert!(mount.up() < -0.99);
        let upright = mount.flipped();
        assert!(upright.up() > 0.99);
        assert!(close(upright.pose2(), Pose2::new(0.2, -0.1, 0.3)));
        let a: f64 = 0.5;
        let beam = mount.rotate([a.cos(), a.sin(), 0.0]);
        assert!((beam[1].atan2(beam[0]) - (0.3 - a)).abs() < 1e-12);
    }

    #[test]
    fn chains_run_through_intermediate_and_sibling_frames() {
        let mut tf = TfTree::default();
        tf.add(
            "base_footprint",
            "base_link",
            0,
            planar(0.0, 0.0, 0.0),
            true,
        );
        tf.add("base_link", "laser_mount", 0, planar(0.1, 0.0, 0.0), true);
        tf.add("laser_mount", "laser", 0, planar(0.1, -0.1, 0.3), true);
        tf.add("base_footprint", "camera", 0, planar(-1.0, 0.0, PI), true);
        for (t, x) in [(30, 3.0), (10, 1.0), (20, 2.0)] {
            tf.add("odom", "base_footprint", t, planar(x, 0.0, 0.0), false);
        }
        tf.finish();
        let mount = tf.lookup("base_link", "laser", 0).unwrap().pose2();
        assert!(close(mount, Pose2::new(0.2, -0.1, 0.3)));
        assert!(tf.is_fixed("base_link", "laser"));
        // Sibling: the camera seen from the laser's mount frame goes up then down.
        let cam = tf.lookup("laser_mount", "camera", 0).unwrap().pose2();
        assert!(close(cam, Pose2::new(-1.1, 0.0, PI)));
        // Moving edges: newest at or before, else the first.
        let at = |t| tf.lookup("odom", "base_link", t).unwrap().t[0];
        assert_eq!((at(5), at(10), at(25), at(99)), (1.0, 1.0, 2.0, 3.0));
        let track = tf.track("odom", "laser").unwrap();
        assert_eq!(track.iter().map(|s| s.0).collect::<Vec<_>>(), [10, 20, 30]);
        assert!((track[2].1.t[0] - 3.2).abs() < 1e-12);
        assert!(!tf.is_fixed("odom", "laser"));
        assert!(tf.track("base_link", "laser").is_none(), "nothing moves");
        assert!(tf.lookup("odom", "map", 0).is_none());
        assert_eq!(tf.children("odom"), ["base_footprint"]);
        assert!(tf.listing().contains("odom→base_footprint (3)"));
    }

    #[test]
    fn a_second_parent_is_ignored_with_a_warning_and_static_keeps_the_newest() {
        let mut tf = TfTree::default();
        tf.add("base_link", "laser", 0, planar(1.0, 0.0, 0.0), true);
        tf.add("base_link", "laser", 0, planar(2.0, 0.0, 0.0), true);
        tf.add("map", "laser", 0, planar(5.0, 0.0, 0.0), true);
        tf.finish();
        assert_eq!(tf.lookup("base_link", "laser", 0).unwrap().t[0], 2.0);
        assert_eq!(tf.warnings.len(), 1);
        assert!(tf.warnings[0].contains("`laser` has parent `base_link`"));
    }
}
