//! Stage 2 of extraction: a circle through a run of returns. The radius first comes from
//! the run's angular width (a pole of radius R at centre distance c subtends 2·asin(R/c));
//! then a geometric least-squares fit (Gauss–Newton on the distances of the points from
//! the circle) moves the centre, and also the radius when the run has enough points to
//! pin it down.

use super::Feature;
use super::segment::Run;
use crate::scan::RangeScan;
use nalgebra::{Matrix3, Vector2, Vector3};

/// Gauss–Newton iterations at most.
const MAX_ITERATIONS: usize = 25;
/// A step shorter than this (m) ends the iteration.
const CONVERGED: f64 = 1e-7;

/// Fits a circle to `run`; `None` when the fit fails (degenerate points, divergence, or
/// a centre in front of the returns). Runs of at least `free_radius_points` returns get
/// their radius fitted too; shorter ones keep the radius from their angular width.
pub fn fit(scan: &RangeScan<'_>, run: &Run, free_radius_points: usize) -> Option<Feature> {
    let n = run.points.len();
    let (first, last) = (run.points.first()?, run.points.last()?);
    let points: Vec<Vector2<f64>> = run
        .points
        .iter()
        .map(|&(i, r)| {
            let a = scan.angle(i);
            Vector2::new(r * a.cos(), r * a.sin())
        })
        .collect();
    let closest = run.points.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    // Radius from the width: the run covers n beams, ≈ the angle the pole subtends.
    let half = (0.5 * n as f64 * scan.angle_increment).min(1.5);
    let radius = closest * half.sin() / (1.0 - half.sin());
    let middle = 0.5 * (scan.angle(first.0) + scan.angle(last.0));
    let mut centre = (closest + radius) * Vector2::new(middle.cos(), middle.sin());
    let mut radius = radius;
    if n >= 2 {
        (centre, radius) = gauss_newton(&points, centre, radius, false)?;
    }
    if n >= free_radius_points
        && let Some((c, r)) = gauss_newton(&points, centre, radius, true)
        && r > 0.0
        && r < 3.0 * radius
    {
        (centre, radius) = (c, r);
    }
    if centre.norm() <= closest || !radius.is_finite() {
        return None;
    }
    let rms = (points
        .iter()
        .map(|p| ((p - centre).norm() - radius).powi(2))
        .sum::<f64>()
        / n as f64)
        .sqrt();
    Some(Feature {
        range: centre.norm(),
        bearing: centre[1].atan2(centre[0]),
        diameter: 2.0 * radius,
        points: n,
        rms,
    })
}

/// Minimises Σ (|pₖ − c| − R)² over the centre c (and R when `fit_radius`).
fn gauss_newton(
    points: &[Vector2<f64>],
    mut centre: Vector2<f64>,
    mut radius: f64,
    fit_radius: bool,
) -> Option<(Vector2<f64>, f64)> {
    for _ in 0..MAX_ITERATIONS {
        let mut jtj = Matrix3::zeros();
        let mut jte = Vector3::zeros();
        for p in points {
            let d = (p - centre).norm();
            if d < 1e-9 {
                return None;
            }
            let u = (p - centre) / d;
            let j = Vector3::new(-u[0], -u[1], if fit_radius { -1.0 } else { 0.0 });
            jtj += j * j.transpose();
            jte += j * (d - radius);
        }
        if !fit_radius {
            jtj[(2, 2)] = 1.0;
        }
        let step = jtj.try_inverse()? * -jte;
        centre += step.xy();
        radius += step[2];
        if !(centre.iter().all(|v| v.is_finite()) && radius.is_finite()) {
            return None;
        }
        if step.norm() < CONVERGED {
            break;
        }
    }
    Some((centre, radius))
}
