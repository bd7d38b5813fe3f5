//! Pictures of a run, as SVG (for a browser) and PNG (for anything else), drawn with
//! plotters and a font compiled into the binary (DejaVu Sans, `assets/fonts`), so neither
//! Python nor system font libraries are needed:
//!
//! - `trajectory`: truth, estimate and dead reckoning over the true and the estimated
//!   landmarks, each estimated landmark with its 2σ covariance ellipse;
//! - `errors`: position error over time (estimate, dead reckoning, the filter's own 2σ
//!   bound) above the pose NEES with the χ²₃ 95 % band;
//! - `rmse_vs_cpu` (for `compare`): trajectory RMSE against the service's CPU time.

use crate::metrics::CHI2_3_95;
use crate::recording::StampedPose;
use crate::timeline::Row;
use fastslam_protocol::MapLandmark;
use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

/// DejaVu Sans (Bitstream Vera licence, `assets/fonts/LICENSE-DejaVu.txt`).
static FONT: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");
/// The family name every text style of the pictures uses.
const FAMILY: &str = "sans-serif";
/// Picture size (pixels; the SVG uses the same units).
pub const SIZE: (u32, u32) = (1200, 900);

/// Truth: black.
pub const TRUTH: RGBColor = RGBColor(0, 0, 0);
/// The service's estimate: blue.
pub const ESTIMATE: RGBColor = RGBColor(31, 119, 180);
/// Dead reckoning: orange.
pub const DEAD_RECKONING: RGBColor = RGBColor(255, 127, 14);
/// Estimated landmarks and their ellipses: red.
pub const LANDMARK: RGBColor = RGBColor(214, 39, 40);
/// The achievable-accuracy reference: green.
pub const REFERENCE: RGBColor = RGBColor(44, 160, 44);
/// The smoothing back-end's trajectory: purple.
pub const SMOOTHED: RGBColor = RGBColor(148, 103, 189);
/// Further series (comparison plot), after the three above.
const PALETTE: [RGBColor; 8] = [
    ESTIMATE,
    DEAD_RECKONING,
    RGBColor(44, 160, 44),
    LANDMARK,
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

/// What drawing a picture can fail with, as text (the backends' error types differ).
pub type PlotResult<T> = Result<T, String>;

fn text<E: std::fmt::Debug>(e: E) -> String {
    format!("{e:?}")
}

/// Something that can draw itself on any plotters backend.
pub trait Picture {
    /// Draws on `area` (already sized [`SIZE`]).
    ///
    /// # Errors
    /// The backend's drawing error, as text.
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> PlotResult<()>;
}

/// Makes the embedded font known to plotters (once per process).
pub fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        if plotters::style::register_font(FAMILY, FontStyle::Normal, FONT).is_err() {
            tracing::warn!("the embedded font could not be loaded: pictures will lack text");
        }
    });
}

/// Writes `picture` as `<dir>/<stem>.svg` and `<dir>/<stem>.png`.
///
/// # Errors
/// When drawing or writing a file fails.
pub fn save(picture: &impl Picture, dir: &Path, stem: &str) -> std::io::Result<()> {
    register_font();
    let io = |e: String| std::io::Error::other(format!("{stem}: {e}"));
    let svg = dir.join(format!("{stem}.svg"));
    {
        let area = SVGBackend::new(&svg, SIZE).into_drawing_area();
        picture.draw(&area).map_err(io)?;
        area.present().map_err(text).map_err(io)?;
    }
    let png = dir.join(format!("{stem}.png"));
    let area = BitMapBackend::new(&png, SIZE).into_drawing_area();
    picture.draw(&area).map_err(io)?;
    area.present().map_err(text).map_err(io)
}

/// A 2-D chart whose axes are built from the ranges `X` and `Y`.
type Chart<'a, DB, X, Y> = ChartContext<
    'a,
    DB,
    Cartesian2d<<X as AsRangedCoord>::CoordDescType, <Y as AsRangedCoord>::CoordDescType>,
>;

/// A chart in the pictures' layout on `area` — optional caption, margins, label areas,
/// axes with their descriptions — ready for its series.
///
/// # Errors
/// The backend's drawing error, as text.
fn new_chart<'a, DB, X, Y>(
    area: &'a DrawingArea<DB, Shift>,
    caption: Option<&str>,
    (x, y): (X, Y),
    (x_desc, y_desc): (&str, &str),
) -> PlotResult<Chart<'a, DB, X, Y>>
where
    DB: DrawingBackend,
    X: AsRangedCoord,
    Y: AsRangedCoord,
    X::CoordDescType: ValueFormatter<X::Value>,
    Y::CoordDescType: ValueFormatter<Y::Value>,
{
    new_chart_with(area, caption, (x, y), (x_desc, y_desc), None)
}

/// How an axis writes its labels.
type Labels<V> = dyn Fn(&V) -> String;

/// [`new_chart`] with the y axis' labels written by `y_labels` (the axis' own formatter
/// when `None`).
///
/// # Errors
/// The backend's drawing error, as text.
fn new_chart_with<'a, DB, X, Y>(
    area: &'a DrawingArea<DB, Shift>,
    caption: Option<&str>,
    (x, y): (X, Y),
    (x_desc, y_desc): (&str, &str),
    y_labels: Option<&Labels<Y::Value>>,
) -> PlotResult<Chart<'a, DB, X, Y>>
where
    DB: DrawingBackend,
    X: AsRangedCoord,
    Y: AsRangedCoord,
    X::CoordDescType: ValueFormatter<X::Value>,
    Y::CoordDescType: ValueFormatter<Y::Value>,
{
    let mut builder = ChartBuilder::on(area);
    if let Some(c) = caption {
        builder.caption(c, (FAMILY, 22));
    }
    let mut chart = builder
        .margin(MARGIN)
        .x_label_area_size(LABEL_AREA.1)
        .y_label_area_size(LABEL_AREA.0)
        .build_cartesian_2d(x, y)
        .map_err(text)?;
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(x_desc)
        .y_desc(y_desc)
        .label_style((FAMILY, 14))
        .light_line_style(WHITE);
    if let Some(f) = y_labels {
        mesh.y_label_formatter(f);
    }
    mesh.draw().map_err(text)?;
    Ok(chart)
}

/// A number as a short axis label: `1e40`, `1e5`, `100`, `1`, `0.1`, `1e-3` — a log
/// axis spans many decades, and a fixed number of decimals cuts the long ones off.
pub fn short_number(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let magnitude = v.abs();
    if (1e-2..1e4).contains(&magnitude) {
        let text = format!("{v:.2}");
        let text = text.trim_end_matches('0').trim_end_matches('.');
        text.to_string()
    } else {
        let text = format!("{v:.1e}");
        text.replace(".0e", "e")
    }
}

/// `track`'s points at least `spacing` apart (the first and last always kept): a dense
/// track (Vicon at 100 Hz) drawn point by point leaves gaps between its sub-pixel
/// segments, so the line looks dotted.
fn thinned(track: &[StampedPose], spacing: f64) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::with_capacity(track.len());
    for (i, p) in track.iter().enumerate() {
        let far = out
            .last()
            .is_none_or(|q| (p.x - q.0).hypot(p.y - q.1) >= spacing);
        if far || i + 1 == track.len() {
            out.push((p.x, p.y));
        }
    }
    out
}

/// Draws the legend of the series drawn so far at `position`.
///
/// # Errors
/// The backend's drawing error, as text.
fn legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
) -> PlotResult<()> {
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font((FAMILY, 14))
        .draw()
        .map_err(text)
}

/// The trajectory picture's data.
#[derive(Debug, Clone, Copy)]
pub struct TrajectoryPlot<'a> {
    /// Ground truth.
    pub truth: &'a [StampedPose],
    /// The service's estimates.
    pub estimate: &'a [StampedPose],
    /// Dead reckoning.
    pub dead_reckoning: &'a [StampedPose],
    /// The achievable-accuracy reference (empty without one).
    pub reference: &'a [StampedPose],
    /// The smoothing back-end's trajectory (empty without one).
    pub smoothed: &'a [StampedPose],
    /// The service's final map (means and covariances).
    pub map: &'a [MapLandmark],
    /// The true landmarks.
    pub true_map: &'a [MapLandmark],
}

/// Pixels beside (y labels) and below (x labels) the plotting area.
const LABEL_AREA: (u32, u32) = (70, 50);
/// Pixels around a chart.
const MARGIN: u32 = 20;

impl TrajectoryPlot<'_> {
    /// Axis ranges covering everything, padded, with equal scale on both axes for a
    /// chart (margins and label areas included) of `size` pixels.
    fn ranges(&self, size: (u32, u32)) -> ((f64, f64), (f64, f64)) {
        let points = [
            self.truth,
            self.estimate,
            self.dead_reckoning,
            self.reference,
            self.smoothed,
        ]
        .into_iter()
        .flatten()
        .map(|p| (p.x, p.y))
        .chain(self.map.iter().chain(self.true_map).map(|l| (l.x, l.y)))
        .filter(|p| p.0.is_finite() && p.1.is_finite());
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for (x, y) in points {
            (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
        }
        if x0 > x1 {
            (x0, x1, y0, y1) = (-1.0, 1.0, -1.0, 1.0);
        }
        let w = f64::from(size.0.saturating_sub(LABEL_AREA.0 + 2 * MARGIN).max(1));
        let h = f64::from(size.1.saturating_sub(LABEL_AREA.1 + 2 * MARGIN).max(1));
        // Metres per pixel: the larger need of the two axes, plus 5 % padding.
        let scale = ((x1 - x0) / w).max((y1 - y0) / h).max(1e-6) * 1.05;
        let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
        (
            (cx - scale * w / 2.0, cx + scale * w / 2.0),
            (cy - scale * h / 2.0, cy + scale * h / 2.0),
        )
    }

    /// Draws the picture and returns the chart's coordinate mapping (for tests that look
    /// for the drawn path).
    ///
    /// # Errors
    /// The backend's drawing error, as text.
    pub fn draw_mapped<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
    ) -> PlotResult<Cartesian2d<RangedCoordf64, RangedCoordf64>> {
        area.fill(&WHITE).map_err(text)?;
        // The title first, so the chart's own area is known to the pixel.
        // A few pixels above the title, so its glyphs are not cut at the edge.
        let area = area
            .margin(8, 0, 0, 0)
            .titled("Trajectory and map", (FAMILY, 24))
            .map_err(text)?;
        let ((x0, x1), (y0, y1)) = self.ranges(area.dim_in_pixel());
        let mut chart = new_chart(&area, None, (x0..x1, y0..y1), ("x (m)", "y (m)"))?;
        // Points closer than about a pixel add nothing but gaps in the drawn line.
        let pixel = (x1 - x0) / f64::from(chart.plotting_area().dim_in_pixel().0.max(1));
        let path = |track: &[StampedPose]| thinned(track, pixel);
        let tracks = [
            (self.dead_reckoning, DEAD_RECKONING, "dead reckoning"),
            (self.truth, TRUTH, "truth"),
            (self.reference, REFERENCE, "achievable (MAP)"),
            (self.smoothed, SMOOTHED, "smoothed"),
            (self.estimate, ESTIMATE, "estimate"),
        ];
        for (track, colour, label) in tracks.into_iter().filter(|t| !t.0.is_empty()) {
            chart
                .draw_series(LineSeries::new(path(track), colour.stroke_width(2)))
                .map_err(text)?
                .label(label)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                });
        }
        if !self.true_map.is_empty() {
            chart
                .draw_series(
                    self.true_map
                        .iter()
                        .map(|l| Cross::new((l.x, l.y), 5, TRUTH.stroke_width(2))),
                )
                .map_err(text)?
                .label("true landmark")
                .legend(|(x, y)| Cross::new((x + 10, y), 5, TRUTH.stroke_width(2)));
        }
        chart
            .draw_series(
                self.map
                    .iter()
                    .map(|l| PathElement::new(ellipse_2sigma(l), LANDMARK.stroke_width(1))),
            )
            .map_err(text)?
            .label("estimated landmark, 2σ")
            .legend(|(x, y)| Circle::new((x + 10, y), 5, LANDMARK.stroke_width(1)));
        chart
            .draw_series(
                self.map
                    .iter()
                    .map(|l| Circle::new((l.x, l.y), 2, LANDMARK.filled())),
            )
            .map_err(text)?;
        legend(&mut chart, SeriesLabelPosition::UpperRight)?;
        Ok(chart.as_coord_spec().clone())
    }
}

impl Picture for TrajectoryPlot<'_> {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> PlotResult<()> {
        self.draw_mapped(area).map(|_| ())
    }
}

/// A landmark's covariance ellipse: the standard deviations along its major and minor
/// axes (m) and the major axis' direction (rad).
pub fn ellipse_axes(l: &MapLandmark) -> (f64, f64, f64) {
    let (a, b, c) = (l.cov_xx, l.cov_xy, l.cov_yy);
    let mid = (a + c) / 2.0;
    let radius = (((a - c) / 2.0).powi(2) + b * b).sqrt();
    (
        (mid + radius).max(0.0).sqrt(),
        (mid - radius).max(0.0).sqrt(),
        0.5 * (2.0 * b).atan2(a - c),
    )
}

/// The closed outline of a landmark's 2σ ellipse (Mahalanobis distance 2 from the mean).
pub fn ellipse_2sigma(l: &MapLandmark) -> Vec<(f64, f64)> {
    let (major, minor, angle) = ellipse_axes(l);
    let (s, co) = angle.sin_cos();
    (0..=48)
        .map(|k| {
            let t = k as f64 / 48.0 * std::f64::consts::TAU;
            let (u, v) = (2.0 * major * t.cos(), 2.0 * minor * t.sin());
            (l.x + co * u - s * v, l.y + s * u + co * v)
        })
        .collect()
}

/// The error picture's data: the run's time series.
#[derive(Debug, Clone, Copy)]
pub struct ErrorPlot<'a> {
    /// One row per estimate.
    pub rows: &'a [Row],
}

impl Picture for ErrorPlot<'_> {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> PlotResult<()> {
        area.fill(&WHITE).map_err(text)?;
        let (top, bottom) = area.split_vertically(area.dim_in_pixel().1 / 2);
        let time = |r: &Row| r.estimate.stamp_ns as f64 * 1e-9;
        let t_end = self.rows.iter().map(time).fold(1e-3, f64::max);
        let series = |f: &dyn Fn(&Row) -> f64| {
            self.rows
                .iter()
                .map(|r| (time(r), f(r)))
                .filter(|p| p.1.is_finite())
                .collect::<Vec<_>>()
        };
        let bound = |r: &Row| 2.0 * r.sigma[0].hypot(r.sigma[1]);
        let errors = [
            (
                series(&|r| r.dead_reckoning_error_m),
                DEAD_RECKONING.stroke_width(2),
                "dead reckoning",
            ),
            (
                series(&|r| r.position_error_m),
                ESTIMATE.stroke_width(2),
                "estimate",
            ),
            (
                series(&bound),
                ESTIMATE.mix(0.4).stroke_width(1),
                "estimate 2σ (filter)",
            ),
        ];
        let e_max = errors
            .iter()
            .flat_map(|(s, ..)| s.iter().map(|p| p.1))
            .fold(1e-3, f64::max)
            .min(1e6);
        let mut chart = new_chart(
            &top,
            Some("Position error over time"),
            (0.0..t_end, 0.0..e_max * 1.05),
            ("time (s)", "position error (m)"),
        )?;
        // A run without ground truth has no errors: only the filter's own bound.
        for (points, style, label) in errors.into_iter().filter(|e| !e.0.is_empty()) {
            chart
                .draw_series(LineSeries::new(points, style))
                .map_err(text)?
                .label(label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
        }
        legend(&mut chart, SeriesLabelPosition::UpperLeft)?;

        // NEES spans many decades when the filter is over-confident: log scale, clamped.
        // Without ground truth no step has a NEES: no series at all.
        let nees = if self.rows.iter().any(|r| r.nees.is_finite()) {
            series(&|r| r.nees.max(1e-6))
        } else {
            Vec::new()
        };
        let n_max = nees.iter().map(|p| p.1).fold(CHI2_3_95 * 2.0, f64::max);
        let n_min = nees.iter().map(|p| p.1).fold(0.1, f64::min);
        let mut chart = new_chart_with(
            &bottom,
            Some("Pose NEES (χ²₃ 95 % band shaded; 3 when consistent)"),
            (0.0..t_end, (n_min..n_max).log_scale()),
            ("time (s)", "NEES"),
            Some(&|v: &f64| short_number(*v)),
        )?;
        let band = RGBColor(44, 160, 44);
        chart
            .draw_series([Rectangle::new(
                [(0.0, n_min), (t_end, CHI2_3_95)],
                band.mix(0.15).filled(),
            )])
            .map_err(text)?
            .label("χ²₃ 95 % band")
            .legend(move |(x, y)| {
                Rectangle::new([(x, y - 5), (x + 20, y + 5)], band.mix(0.3).filled())
            });
        chart
            .draw_series(LineSeries::new(
                [(0.0, 3.0), (t_end, 3.0)],
                band.stroke_width(1),
            ))
            .map_err(text)?;
        if !nees.is_empty() {
            chart
                .draw_series(LineSeries::new(nees, ESTIMATE.stroke_width(1)))
                .map_err(text)?
                .label("NEES")
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], ESTIMATE.stroke_width(2))
                });
        }
        legend(&mut chart, SeriesLabelPosition::UpperLeft)
    }
}

/// One optimiser's runs in the comparison plot: (service CPU time in s, trajectory RMSE
/// in m) per run, and the per-configuration means joined by a line.
#[derive(Debug, Clone, PartialEq)]
pub struct CostSeries {
    /// The optimiser's name.
    pub name: String,
    /// Every run: (CPU s, RMSE m).
    pub runs: Vec<(f64, f64)>,
    /// Mean per particle count, in particle order: (CPU s, RMSE m).
    pub means: Vec<(f64, f64)>,
}

/// Trajectory RMSE against the service's CPU time, one colour per optimiser.
#[derive(Debug, Clone)]
pub struct CostPlot {
    /// The optimisers' series.
    pub series: Vec<CostSeries>,
}

impl Picture for CostPlot {
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> PlotResult<()> {
        area.fill(&WHITE).map_err(text)?;
        let all = || {
            self.series
                .iter()
                .flat_map(|s| s.runs.iter())
                .filter(|p| p.0.is_finite() && p.1.is_finite())
        };
        let x_max = all().map(|p| p.0).fold(1e-3, f64::max) * 1.1;
        let y_max = all().map(|p| p.1).fold(1e-3, f64::max) * 1.1;
        let mut chart = new_chart(
            area,
            Some("Trajectory RMSE vs CPU time of the service"),
            (0.0..x_max, 0.0..y_max),
            ("service CPU time per run (s)", "trajectory RMSE (m)"),
        )?;
        for (s, colour) in self.series.iter().zip(PALETTE.iter().cycle()) {
            let colour = *colour;
            chart
                .draw_series(s.runs.iter().map(|&p| Circle::new(p, 4, colour.filled())))
                .map_err(text)?
                .label(s.name.as_str())
                .legend(move |(x, y)| Circle::new((x + 10, y), 4, colour.filled()));
            chart
                .draw_series(LineSeries::new(
                    s.means.iter().copied(),
                    colour.stroke_width(2),
                ))
                .map_err(text)?;
        }
        legend(&mut chart, SeriesLabelPosition::UpperRight)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(k: u64, x: f64, y: f64) -> StampedPose {
        StampedPose {
            stamp_ns: k,
            x,
            y,
            theta: 0.0,
        }
    }

    #[test]
    fn the_trajectory_is_drawn_where_the_chart_maps_it() {
        register_font();
        // A circle of radius 50 m; the estimate runs 5 m outside it.
        let circle = |r: f64| -> Vec<StampedPose> {
            (0..200)
                .map(|k| {
                    let a = k as f64 / 200.0 * std::f64::consts::TAU;
                    pose(k, r * a.cos(), r * a.sin())
                })
                .collect()
        };
        let (truth, estimate) = (circle(50.0), circle(55.0));
        let plot = TrajectoryPlot {
            truth: &truth,
            estimate: &estimate,
            dead_reckoning: &[],
            reference: &[],
            smoothed: &[],
            map: &[],
            true_map: &[],
        };
        let (w, h) = (600_u32, 450_u32);
        let mut buf = vec![0_u8; (w * h * 3) as usize];
        let mapping = {
            let area = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            let m = plot.draw_mapped(&area).unwrap();
            area.present().unwrap();
            m
        };

        let pixel = |(x, y): (i32, i32)| {
            let i = ((y as u32 * w + x as u32) * 3) as usize;
            RGBColor(buf[i], buf[i + 1], buf[i + 2])
        };
        // Every truth sample lands on a truth-coloured pixel (or one next to it), except
        // under the legend box (upper right), which covers about a tenth of this circle.
        let near = |c: (i32, i32), colour: RGBColor| {
            (-1..=1).any(|dx| (-1..=1).any(|dy| pixel((c.0 + dx, c.1 + dy)) == colour))
        };
        let hits = |track: &[StampedPose], colour| {
            track
                .iter()
                .filter(|p| near(mapping.translate(&(p.x, p.y)), colour))
                .count()
        };
        assert!(
            hits(&truth, TRUTH) >= 170,
            "truth drawn: {}",
            hits(&truth, TRUTH)
        );
        assert!(hits(&estimate, ESTIMATE) >= 170);
        // And the samples are not in the other track's colour: the mapping is exact.
        let crossed = (hits(&truth, ESTIMATE), hits(&estimate, TRUTH));
        assert!(crossed.0 < 10 && crossed.1 < 10, "{crossed:?}");
        // Equal scale: the circle is as wide as it is high on screen.
        let (l, r) = (
            mapping.translate(&(-50.0, 0.0)),
            mapping.translate(&(50.0, 0.0)),
        );
        let (b, t) = (
            mapping.translate(&(0.0, -50.0)),
            mapping.translate(&(0.0, 50.0)),
        );
        assert!(
            ((r.0 - l.0) - (b.1 - t.1)).abs() <= 2,
            "{l:?} {r:?} {b:?} {t:?}"
        );
        // Inside the circle, off the grid lines, nothing is drawn.
        for inside in [(3.7, 6.1), (-13.3, -8.9), (21.1, -23.7)] {
            assert_eq!(pixel(mapping.translate(&inside)), WHITE, "{inside:?}");
        }
    }

    #[test]
    fn log_axis_labels_are_short() {
        let cases = [
            (2e40, "2e40"),
            (1e5, "1e5"),
            (100.0, "100"),
            (1.0, "1"),
            (0.1, "0.1"),
            (2.5, "2.5"),
            (1e-3, "1e-3"),
        ];
        for (v, text) in cases {
            assert_eq!(short_number(v), text, "{v}");
        }
    }

    #[test]
    fn dense_tracks_are_thinned_to_the_pixel_keeping_both_ends() {
        let track: Vec<StampedPose> = (0..=100).map(|k| pose(k, k as f64 * 0.01, 0.0)).collect();
        let points = thinned(&track, 0.095);
        assert_eq!(points.len(), 11, "{points:?}");
        assert_eq!(points[0], (0.0, 0.0));
        assert_eq!(*points.last().unwrap(), (1.0, 0.0));
        assert!(points.windows(2).all(|w| w[1].0 - w[0].0 >= 0.095));
    }

    #[test]
    fn a_two_sigma_ellipse_has_the_right_axes() {
        let l = MapLandmark {
            x: 1.0,
            y: 2.0,
            cov_xx: 4.0,
            cov_xy: 0.0,
            cov_yy: 1.0,
            ..Default::default()
        };
        let e = ellipse_2sigma(&l);
        let max_dx = e.iter().map(|p| (p.0 - 1.0).abs()).fold(0.0, f64::max);
        let max_dy = e.iter().map(|p| (p.1 - 2.0).abs()).fold(0.0, f64::max);
        assert!(
            (max_dx - 4.0).abs() < 1e-9 && (max_dy - 2.0).abs() < 0.01,
            "{max_dx} {max_dy}"
        );
        // Every outline point is at Mahalanobis distance 2.
        for p in e {
            let d2 = (p.0 - 1.0).powi(2) / 4.0 + (p.1 - 2.0).powi(2) / 1.0;
            assert!((d2 - 4.0).abs() < 1e-9);
        }
    }
}
