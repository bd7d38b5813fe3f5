//! What the estimation crate's integration tests share: a ray cast against wall segments
//! and the full-turn laser that scans them, a ring corridor to drive round, and a
//! simulated run for the FastSLAM behaviour tests.

#![allow(dead_code)] // each test binary uses a different subset

pub mod bailey;

use fastslam_estimation::Pose2;
use fastslam_estimation::rng::seeded;
use rand::RngExt;
use rand_distr::StandardNormal;

/// A wall from `(x1, y1)` to `(x2, y2)`: `[x1, y1, x2, y2]` (m).
pub type Segment = [f64; 4];

/// Beams per scan of the simulated laser, evenly over a full turn (1° apart).
pub const BEAMS: usize = 360;

/// Direction of beam `i` of the simulated laser (rad, sensor frame), from −π.
pub fn beam_angle(i: usize) -> f64 {
    -std::f64::consts::PI + i as f64 * std::f64::consts::TAU / BEAMS as f64
}

/// A scan of the simulated laser at `pose` in `world`: ranges with `noise` (m, 1σ)
/// drawn from `seed`.
pub fn scan(world: &[Segment], pose: &Pose2, noise: f64, seed: u64) -> Vec<f64> {
    let mut rng = seeded(seed);
    (0..BEAMS)
        .map(|i| {
            let a = pose.theta + beam_angle(i);
            let r = cast(world, pose.x, pose.y, a);
            r + noise * rng.sample::<f64, _>(StandardNormal)
        })
        .collect()
}

/// Range along the ray from `(x, y)` at angle `a` to the nearest segment of `world`
/// (∞ if none).
pub fn cast(world: &[Segment], x: f64, y: f64, a: f64) -> f64 {
    let (dx, dy) = (a.cos(), a.sin());
    world
        .iter()
        .filter_map(|w| {
            let (ex, ey) = (w[2] - w[0], w[3] - w[1]);
            let den = dx * ey - dy * ex;
            if den.abs() < 1e-12 {
                return None;
            }
            let (qx, qy) = (w[0] - x, w[1] - y);
            let t = (qx * ey - qy * ex) / den;
            let u = (qx * dy - qy * dx) / den;
            (t > 0.0 && (0.0..=1.0).contains(&u)).then_some(t)
        })
        .fold(f64::INFINITY, f64::min)
}

/// The four sides of an axis-aligned box `[x1, y1, x2, y2]`.
pub fn rectangle(b: [f64; 4]) -> [Segment; 4] {
    [
        [b[0], b[1], b[2], b[1]],
        [b[2], b[1], b[2], b[3]],
        [b[2], b[3], b[0], b[3]],
        [b[0], b[3], b[0], b[1]],
    ]
}

/// A square ring corridor 2 m wide around the path (0,0) → (10,0) → (10,10) → (0,10),
/// with 0.3 m boxes against its walls at uneven places so that no stretch is featureless.
pub fn corridor_world() -> Vec<Segment> {
    let mut world = Vec::new();
    world.extend(rectangle([-1.0, -1.0, 11.0, 11.0]));
    world.extend(rectangle([1.0, 1.0, 9.0, 9.0]));
    // (position along the side, outer wall?) per side; sides run counter-clockwise.
    let boxes: [&[(f64, bool)]; 4] = [
        &[
            (1.3, true),
            (2.7, false),
            (4.1, true),
            (6.2, false),
            (8.6, true),
        ],
        &[(1.8, false), (3.2, true), (5.9, true), (7.4, false)],
        &[(2.2, true), (4.6, false), (6.9, true), (8.1, false)],
        &[(1.6, true), (3.9, false), (5.3, true), (7.7, true)],
    ];
    let s = 0.3;
    for (side, list) in boxes.iter().enumerate() {
        for &(along, outer) in *list {
            // In the side's frame: x along the side, y towards the outer wall is negative.
            let (y0, y1) = if outer {
                (-1.0, -1.0 + s)
            } else {
                (1.0 - s, 1.0)
            };
            let corners = [(along, y0), (along + s, y1)];
            let map = |(u, v): (f64, f64)| match side {
                0 => (u, v),
                1 => (10.0 - v, u),
                2 => (10.0 - u, 10.0 - v),
                _ => (v, 10.0 - u),
            };
            let (a, b) = (map(corners[0]), map(corners[1]));
            world.extend(rectangle([
                a.0.min(b.0),
                a.1.min(b.1),
                a.0.max(b.0),
                a.1.max(b.1),
            ]));
        }
    }
    world
}
