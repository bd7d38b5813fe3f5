//! What the estimation crate's integration tests share: a ray cast against wall segments
//! for their simulated lasers, and a simulated run for the FastSLAM behaviour tests.

#![allow(dead_code)] // each test binary uses a different subset

pub mod bailey;

/// A wall from `(x1, y1)` to `(x2, y2)`: `[x1, y1, x2, y2]` (m).
pub type Segment = [f64; 4];

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
