//! Pose graphs in the g2o text format, 2D: read (plain or gzip, told apart by the gzip
//! magic bytes) into a [`Graph`], and written back.
//!
//! One record a line, fields separated by white space; blank lines and lines starting
//! with `#` are skipped:
//!
//! | tag | fields |
//! | --- | --- |
//! | `VERTEX_SE2` | `id x y θ` |
//! | `VERTEX_XY` | `id x y` |
//! | `EDGE_SE2` | `i j dx dy dθ I11 I12 I13 I22 I23 I33` (upper triangle of the information) |
//! | `EDGE_SE2_XY` | `i j dx dy I11 I12 I22` (pose `i` sees landmark `j` at `(dx, dy)`) |
//! | `FIX` | `id …` (poses held at their initial value) |
//!
//! Ids may be sparse and in any order (poses and landmarks share one id space): poses are
//! numbered by ascending id, landmarks too. A pose edge becomes a [`Between`] with the
//! SE(2) logarithm residual ([`PoseResidual::Logmap`], GTSAM's convention), a landmark
//! edge an [`Offset`]. The gauge is a prior of information [`ANCHOR_INFORMATION`] `· I` on
//! every fixed pose, or on the first pose (lowest id) when the file fixes none — GTSAM's
//! "prior on the first pose"; [`Graph::chi2_measurements`] is then the χ² over the edges
//! alone.

use super::{Between, Graph, Offset, PoseResidual, Prior};
use crate::pose::Pose2;
use nalgebra::{Matrix2, Matrix3, Vector2};
use std::collections::HashMap;
use std::io::{BufRead, BufReader, Write};
use std::path::Path;

/// Information (per unit, on x, y and θ) of the prior that anchors a read graph: a
/// standard deviation of 10⁻⁴ m and rad.
pub const ANCHOR_INFORMATION: f64 = 1e8;

/// What went wrong reading or writing a g2o file.
#[derive(Debug, thiserror::Error)]
pub enum G2oError {
    /// The file could not be read or written.
    #[error("{0}")]
    Io(#[from] std::io::Error),
    /// A line that is not a valid record, or refers to a vertex the file lacks.
    #[error("line {line}: {reason}")]
    Line {
        /// Its number, from 1.
        line: usize,
        /// What is wrong with it.
        reason: String,
    },
    /// A graph with a factor the format has no record for.
    #[error("cannot write as g2o: {0}")]
    Unwritable(String),
}

/// A g2o pose graph: the [`Graph`] and the file's vertex ids.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct G2o {
    /// The variables (poses by ascending id, then landmarks by ascending id), the edges
    /// and the anchoring priors.
    pub graph: Graph,
    /// The file's id of each pose, by pose index.
    pub pose_ids: Vec<i64>,
    /// The file's id of each landmark, by landmark index.
    pub landmark_ids: Vec<i64>,
    /// The poses the file fixed (`FIX`), as ids.
    pub fixed: Vec<i64>,
}

/// A vertex as read, before numbering.
enum Vertex {
    Pose(Pose2),
    Point(Vector2<f64>),
}

/// An edge as read, with its line, before numbering.
enum Edge {
    Pose {
        line: usize,
        ids: (i64, i64),
        delta: Pose2,
        information: Matrix3<f64>,
    },
    Point {
        line: usize,
        ids: (i64, i64),
        offset: Vector2<f64>,
        information: Matrix2<f64>,
    },
}

/// Reads the g2o file at `path`, gzipped or not.
///
/// # Errors
/// [`G2oError::Io`] when it cannot be read, [`G2oError::Line`] for the first bad line.
pub fn read(path: &Path) -> Result<G2o, G2oError> {
    let mut file = BufReader::new(std::fs::File::open(path)?);
    let gzipped = file.fill_buf()?.starts_with(&[0x1f, 0x8b]);
    if gzipped {
        parse(BufReader::new(flate2::read::MultiGzDecoder::new(file)))
    } else {
        parse(file)
    }
}

/// Parses g2o text; see the module documentation.
///
/// # Errors
/// [`G2oError::Io`] when the text cannot be read, [`G2oError::Line`] for the first bad line
/// (an unknown tag, a wrong field count, a number that is not finite, a duplicate vertex
/// id, an edge to a vertex the file lacks or of the wrong kind).
pub fn parse(reader: impl BufRead) -> Result<G2o, G2oError> {
    let mut vertices: HashMap<i64, (usize, Vertex)> = HashMap::new();
    let mut edges = Vec::new();
    let mut fixed: Vec<(usize, i64)> = Vec::new();
    for (index, text) in reader.lines().enumerate() {
        let (line, text) = (index + 1, text?);
        let mut fields = text.split_whitespace();
        let Some(tag) = fields.next() else { continue };
        if tag.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = fields.collect();
        let bad = |reason: String| G2oError::Line { line, reason };
        let count = |n: usize| {
            if fields.len() == n {
                Ok(())
            } else {
                Err(bad(format!("{tag} takes {n} fields, not {}", fields.len())))
            }
        };
        let id = |k: usize| {
            (fields[k].parse::<i64>()).map_err(|_| bad(format!("bad id `{}`", fields[k])))
        };
        let numbers = |from: usize| -> Result<Vec<f64>, G2oError> {
            (fields[from..].iter())
                .map(|f| match f.parse::<f64>() {
                    Ok(v) if v.is_finite() => Ok(v),
                    _ => Err(bad(format!("bad number `{f}`"))),
                })
                .collect()
        };
        let mut vertex = |vertex: Vertex| {
            let id = id(0)?;
            match vertices.insert(id, (line, vertex)) {
                Some((first, _)) => Err(bad(format!("vertex {id} also on line {first}"))),
                None => Ok(()),
            }
        };
        match tag {
            "VERTEX_SE2" => {
                count(4)?;
                let v = numbers(1)?;
                vertex(Vertex::Pose(Pose2::new(v[0], v[1], v[2])))?;
            }
            "VERTEX_XY" => {
                count(3)?;
                let v = numbers(1)?;
                vertex(Vertex::Point(Vector2::new(v[0], v[1])))?;
            }
            "EDGE_SE2" => {
                count(11)?;
                let v = numbers(2)?;
                let information = Matrix3::new(
                    v[3], v[4], v[5], //
                    v[4], v[6], v[7], //
                    v[5], v[7], v[8],
                );
                edges.push(Edge::Pose {
                    line,
                    ids: (id(0)?, id(1)?),
                    delta: Pose2::new(v[0], v[1], v[2]),
                    information,
                });
            }
            "EDGE_SE2_XY" => {
                count(7)?;
                let v = numbers(2)?;
                edges.push(Edge::Point {
                    line,
                    ids: (id(0)?, id(1)?),
                    offset: Vector2::new(v[0], v[1]),
                    information: Matrix2::new(v[2], v[3], v[3], v[4]),
                });
            }
            "FIX" => {
                if fields.is_empty() {
                    return Err(bad("FIX names no vertex".into()));
                }
                for k in 0..fields.len() {
                    fixed.push((line, id(k)?));
                }
            }
            _ => return Err(bad(format!("unknown tag `{tag}`"))),
        }
    }
    assemble(vertices, edges, &fixed)
}

/// Numbers the vertices, resolves the edges' ids and anchors the graph.
fn assemble(
    vertices: HashMap<i64, (usize, Vertex)>,
    edges: Vec<Edge>,
    fixed: &[(usize, i64)],
) -> Result<G2o, G2oError> {
    let mut ids: Vec<i64> = vertices.keys().copied().collect();
    ids.sort_unstable();
    let mut g2o = G2o::default();
    // Index of each id among its kind.
    let mut index: HashMap<i64, usize> = HashMap::with_capacity(ids.len());
    for id in ids {
        match &vertices[&id].1 {
            Vertex::Pose(p) => {
                index.insert(id, g2o.graph.add_pose(*p));
                g2o.pose_ids.push(id);
            }
            Vertex::Point(m) => {
                index.insert(id, g2o.graph.add_landmark(*m));
                g2o.landmark_ids.push(id);
            }
        }
    }
    let is_pose = |id: i64| matches!(vertices.get(&id), Some((_, Vertex::Pose(_))));
    let find = |line: usize, id: i64, pose: bool| {
        let kind = if pose { "pose" } else { "landmark" };
        match vertices.get(&id) {
            Some(_) if is_pose(id) == pose => Ok(index[&id]),
            Some((at, _)) => Err(G2oError::Line {
                line,
                reason: format!("vertex {id} (line {at}) is not a {kind}"),
            }),
            None => Err(G2oError::Line {
                line,
                reason: format!("no {kind} vertex {id}"),
            }),
        }
    };
    for edge in edges {
        match edge {
            Edge::Pose {
                line,
                ids,
                delta,
                information,
            } => g2o.graph.betweens.push(Between {
                from: find(line, ids.0, true)?,
                to: find(line, ids.1, true)?,
                delta,
                information,
                residual: PoseResidual::Logmap,
            }),
            Edge::Point {
                line,
                ids,
                offset,
                information,
            } => g2o.graph.offsets.push(Offset {
                pose: find(line, ids.0, true)?,
                landmark: find(line, ids.1, false)?,
                offset,
                information,
            }),
        }
    }
    let mut anchors = Vec::new();
    for &(line, id) in fixed {
        let pose = find(line, id, true)?;
        if !anchors.contains(&pose) {
            anchors.push(pose);
            g2o.fixed.push(id);
        }
    }
    if anchors.is_empty() && !g2o.graph.poses.is_empty() {
        anchors.push(0);
    }
    for pose in anchors {
        g2o.graph.priors.push(Prior {
            pose,
            mean: g2o.graph.poses[pose],
            information: Matrix3::identity() * ANCHOR_INFORMATION,
        });
    }
    Ok(g2o)
}

impl G2o {
    /// `graph` in the format's terms, its variables numbered poses first, then
    /// landmarks: componentwise odometry factors become SE(2)-logarithm edges with their
    /// information turned into the measurement's frame, range–bearing sightings become
    /// `EDGE_SE2_XY` offsets `(r cos b, r sin b)` with their covariance carried through the
    /// polar-to-Cartesian Jacobian at the measurement — the same problem to first order
    /// about the measurements — and the posed priors become `FIX` lines. Landmark priors
    /// are left out (a window's, not a graph's).
    pub fn from_graph(graph: &Graph) -> Self {
        let mut out = Graph {
            poses: graph.poses.clone(),
            landmarks: graph.landmarks.clone(),
            offsets: graph.offsets.clone(),
            ..Graph::default()
        };
        out.betweens = (graph.betweens.iter())
            .map(|b| match b.residual {
                PoseResidual::Logmap => *b,
                PoseResidual::Componentwise => {
                    // To first order the logarithm's translation is the componentwise one
                    // turned by −θ_δ: r_c = T r_l, so Ω_l = Tᵀ Ω_c T.
                    let (s, c) = b.delta.theta.sin_cos();
                    let t = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
                    Between {
                        information: t.transpose() * b.information * t,
                        residual: PoseResidual::Logmap,
                        ..*b
                    }
                }
            })
            .collect();
        out.offsets.extend(graph.sightings.iter().filter_map(|s| {
            let (r, (sb, cb)) = (s.z[0], s.z[1].sin_cos());
            let g = Matrix2::new(cb, -r * sb, sb, r * cb);
            let g_inv = g.try_inverse()?;
            Some(Offset {
                pose: s.pose,
                landmark: s.landmark,
                offset: Vector2::new(r * cb, r * sb),
                information: g_inv.transpose() * s.information * g_inv,
            })
        }));
        // A fixed vertex is held at its value: the prior's mean.
        let np = graph.poses.len() as i64;
        let mut fixed = Vec::new();
        for p in &graph.priors {
            out.poses[p.pose] = p.mean;
            if !fixed.contains(&(p.pose as i64)) {
                fixed.push(p.pose as i64);
                out.priors.push(Prior {
                    information: Matrix3::identity() * ANCHOR_INFORMATION,
                    ..*p
                });
            }
        }
        Self {
            graph: out,
            pose_ids: (0..np).collect(),
            landmark_ids: (np..np + graph.landmarks.len() as i64).collect(),
            fixed,
        }
    }

    /// Number of edges (pose edges and landmark edges).
    pub fn edges(&self) -> usize {
        self.graph.betweens.len() + self.graph.offsets.len()
    }

    /// Writes the graph at its current estimates as g2o text: vertices by index, `FIX`
    /// lines, pose edges, landmark edges; numbers in their shortest form that reads back
    /// exactly (`1.5`, `4.3e-18`), so a file read back gives the same graph.
    ///
    /// # Errors
    /// [`G2oError::Unwritable`] for a sighting (range–bearing: no 2D g2o record), a
    /// componentwise [`Between`] (its residual is not the format's) or a graph whose
    /// vertex ids do not match its variables; [`G2oError::Io`] when `out` fails.
    pub fn write(&self, out: impl Write) -> Result<(), G2oError> {
        let graph = &self.graph;
        if !graph.sightings.is_empty() {
            return Err(G2oError::Unwritable("range–bearing sightings".into()));
        }
        if !graph.landmark_priors.is_empty() {
            return Err(G2oError::Unwritable("landmark priors".into()));
        }
        if (graph.betweens.iter()).any(|b| b.residual != PoseResidual::Logmap) {
            return Err(G2oError::Unwritable(
                "componentwise odometry factors".into(),
            ));
        }
        if self.pose_ids.len() != graph.poses.len()
            || self.landmark_ids.len() != graph.landmarks.len()
        {
            return Err(G2oError::Unwritable(format!(
                "{} pose ids for {} poses, {} landmark ids for {} landmarks",
                self.pose_ids.len(),
                graph.poses.len(),
                self.landmark_ids.len(),
                graph.landmarks.len()
            )));
        }
        let mut out = std::io::BufWriter::new(out);
        for (id, p) in self.pose_ids.iter().zip(&graph.poses) {
            writeln!(out, "VERTEX_SE2 {id} {:?} {:?} {:?}", p.x, p.y, p.theta)?;
        }
        for (id, m) in self.landmark_ids.iter().zip(&graph.landmarks) {
            writeln!(out, "VERTEX_XY {id} {:?} {:?}", m.x, m.y)?;
        }
        for id in &self.fixed {
            writeln!(out, "FIX {id}")?;
        }
        for b in &graph.betweens {
            let (i, d) = (&b.information, &b.delta);
            writeln!(
                out,
                "EDGE_SE2 {} {} {:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?}",
                self.pose_ids[b.from],
                self.pose_ids[b.to],
                d.x,
                d.y,
                d.theta,
                i[(0, 0)],
                i[(0, 1)],
                i[(0, 2)],
                i[(1, 1)],
                i[(1, 2)],
                i[(2, 2)]
            )?;
        }
        for o in &graph.offsets {
            let i = &o.information;
            writeln!(
                out,
                "EDGE_SE2_XY {} {} {:?} {:?} {:?} {:?} {:?}",
                self.pose_ids[o.pose],
                self.landmark_ids[o.landmark],
                o.offset.x,
                o.offset.y,
                i[(0, 0)],
                i[(0, 1)],
                i[(1, 1)]
            )?;
        }
        out.flush()?;
        Ok(())
    }

    /// Writes the graph ([`write`](Self::write)) to the file at `path`, gzipped when the
    /// name ends in `.gz`.
    ///
    /// # Errors
    /// As [`write`](Self::write), and when the file cannot be created.
    pub fn save(&self, path: &Path) -> Result<(), G2oError> {
        let file = std::fs::File::create(path)?;
        if path.extension().is_some_and(|e| e == "gz") {
            let mut gz = flate2::write::GzEncoder::new(file, flate2::Compression::default());
            self.write(&mut gz)?;
            gz.finish()?;
            Ok(())
        } else {
            self.write(file)
        }
    }
}

/// Parses g2o text already in memory ([`parse`]).
///
/// # Errors
/// As [`parse`].
pub fn parse_str(text: &str) -> Result<G2o, G2oError> {
    parse(text.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::SolveOptions;

    /// A four-pose loop turning 0.5 rad a step with anisotropic odometry information and
    /// two landmarks seen by range and bearing, at the true values shifted by `shift`.
    fn turning(shift: f64) -> Graph {
        use crate::observation::{Observation, measure};
        let truth: Vec<Pose2> = (0..4)
            .map(|k| {
                let a = 0.5 * f64::from(k);
                Pose2::new(3.0 * a.sin(), 3.0 * (1.0 - a.cos()), a)
            })
            .collect();
        let marks = [Vector2::new(1.0, 4.0), Vector2::new(4.0, 0.5)];
        let mut graph = Graph::default();
        for (k, p) in truth.iter().enumerate() {
            let (w, sign) = (
                shift * (k as f64 + 1.0),
                if k % 2 == 0 { 1.0 } else { -1.0 },
            );
            graph.add_pose(Pose2::new(
                p.x + w * w / shift,
                p.y + 2.0 * sign * w,
                p.theta + sign * w,
            ));
        }
        for m in &marks {
            graph.add_landmark(m + Vector2::new(shift, shift));
        }
        graph.priors.push(Prior {
            pose: 0,
            mean: truth[0],
            information: Matrix3::identity() * 1e8,
        });
        for k in 1..4 {
            graph.betweens.push(Between {
                from: k - 1,
                to: k,
                delta: truth[k - 1].inverse().compose(&truth[k]),
                information: Matrix3::from_diagonal(&nalgebra::Vector3::new(100.0, 1.0, 50.0)),
                residual: PoseResidual::Componentwise,
            });
        }
        let noise = Matrix2::from_diagonal(&Vector2::new(0.01, 0.0004));
        for (k, p) in truth.iter().enumerate() {
            for (j, m) in marks.iter().enumerate() {
                let z = measure(p, m);
                let seen = Observation {
                    range: z[0],
                    bearing: z[1],
                    id: None,
                };
                graph.add_sighting(k, j, &seen, &noise).unwrap();
            }
        }
        graph
    }

    #[test]
    fn a_range_bearing_graph_written_as_g2o_is_the_same_problem_to_first_order() {
        // Near the measurements the two forms' χ² agree to first order, the odometry's
        // and the sightings' each.
        let (graph, near) = (turning(5e-3), G2o::from_graph(&turning(5e-3)));
        let parts = |g: &Graph| {
            let odometry = Graph {
                sightings: Vec::new(),
                offsets: Vec::new(),
                ..g.clone()
            };
            let seen = Graph {
                betweens: Vec::new(),
                ..g.clone()
            };
            [odometry.chi2_measurements(), seen.chi2_measurements()]
        };
        for (a, b) in parts(&graph).into_iter().zip(parts(&near.graph)) {
            assert!(a > 0.1, "{a}: the shift must show");
            assert!((a - b).abs() < 0.05 * a, "{a} against {b}");
        }
        // … the file reads back as written, and both solve to the truth.
        let mut text = Vec::new();
        near.write(&mut text).unwrap();
        let mut read = parse_str(std::str::from_utf8(&text).unwrap()).unwrap();
        assert_eq!(read.graph.offsets.len(), 8);
        assert_eq!(read.graph.betweens.len(), 3);
        let mut solved = turning(0.05);
        solved.solve(&SolveOptions::default()).unwrap();
        read.graph.solve(&SolveOptions::pose_graph()).unwrap();
        for (p, q) in solved.poses.iter().zip(&read.graph.poses) {
            assert!((p.x - q.x).abs() + (p.y - q.y).abs() + (p.theta - q.theta).abs() < 1e-6);
        }
        assert!(read.graph.chi2_measurements() < 1e-9);
    }

    /// Three poses on a line, ids out of order, whose three edges disagree by 0.3 m round
    /// the loop, with x-information 1, 2 and 4; and one landmark seen once. Linear in x
    /// at the solution (y = θ = 0): residuals `e` with `e₁ + e₂ − e₃ = 0.3` minimising
    /// `Σ wᵢ eᵢ²` give `χ² = 0.3² / Σ 1/wᵢ`.
    const TRIANGLE: &str = "\
# a small loop
VERTEX_SE2 10 0 0 0
VERTEX_SE2 7 2.5 0.2 -0.1
VERTEX_SE2 3 0.9 -0.1 0.05

VERTEX_XY 42 1.0 3.0
EDGE_SE2 10 3 1 0 0 1 0 0 5 0.5 7
EDGE_SE2 3 7 1 0 0 2 0 0 5 -0.3 7
EDGE_SE2 10 7 2.3 0 0 4 0 0 5 0 7
EDGE_SE2_XY 3 42 0.5 2.0 3 0.2 3
";

    #[test]
    fn a_small_loop_solves_to_its_hand_computed_chi2() {
        let mut g2o = parse_str(TRIANGLE).unwrap();
        assert_eq!(g2o.pose_ids, [3, 7, 10]);
        assert_eq!(g2o.landmark_ids, [42]);
        assert_eq!((g2o.graph.poses.len(), g2o.edges()), (3, 4));
        // The first pose (lowest id, 3) is the anchor.
        assert_eq!(g2o.graph.priors.len(), 1);
        assert_eq!(g2o.graph.priors[0].pose, 0);
        let report = g2o.graph.solve(&SolveOptions::pose_graph()).unwrap();
        assert!(report.converged, "{report:?}");
        let expected = 0.09 / (1.0 + 0.5 + 0.25);
        let chi2 = g2o.graph.chi2_measurements();
        assert!((chi2 - expected).abs() < 1e-9, "{chi2} vs {expected}");
        // The anchor held: pose 3 stayed where it started.
        let first = g2o.graph.poses[0];
        assert!((first.x - 0.9).abs() < 1e-7 && (first.y + 0.1).abs() < 1e-7);
    }

    #[test]
    fn a_fixed_pose_is_the_anchor_and_a_written_graph_reads_back_the_same() {
        let text = format!("{TRIANGLE}FIX 7\n");
        let mut g2o = parse_str(&text).unwrap();
        assert_eq!(g2o.fixed, [7]);
        assert_eq!(g2o.graph.priors.len(), 1);
        assert_eq!(g2o.graph.priors[0].pose, 1);
        g2o.graph.solve(&SolveOptions::pose_graph()).unwrap();
        let mut written = Vec::new();
        g2o.write(&mut written).unwrap();
        let again = parse(written.as_slice()).unwrap();
        assert_eq!(again.graph.poses, g2o.graph.poses);
        assert_eq!(again.graph.landmarks, g2o.graph.landmarks);
        assert_eq!(again.graph.betweens, g2o.graph.betweens);
        assert_eq!(again.graph.offsets, g2o.graph.offsets);
        assert_eq!(again.fixed, g2o.fixed);
    }

    #[test]
    fn a_gzipped_file_reads_as_the_plain_one() {
        let dir = std::env::temp_dir().join(format!("g2o-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let plain = parse_str(TRIANGLE).unwrap();
        let path = dir.join("triangle.g2o.gz");
        plain.save(&path).unwrap();
        let gzipped = read(&path).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(gzipped, plain);
    }

    #[test]
    fn a_malformed_line_is_an_error_naming_its_line() {
        let short = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0\n";
        let error = parse_str(short).unwrap_err().to_string();
        assert_eq!(error, "line 3: EDGE_SE2 takes 11 fields, not 10");
        let unknown = "VERTEX_SE2 0 0 0 0\n\nEDGE_SE3:QUAT 0 1\n";
        let error = parse_str(unknown).unwrap_err().to_string();
        assert_eq!(error, "line 3: unknown tag `EDGE_SE3:QUAT`");
        let number = "VERTEX_SE2 0 0 nan 0\n";
        assert_eq!(
            parse_str(number).unwrap_err().to_string(),
            "line 1: bad number `nan`"
        );
        let missing = "VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 5 1 0 0 1 0 0 1 0 1\n";
        assert_eq!(
            parse_str(missing).unwrap_err().to_string(),
            "line 2: no pose vertex 5"
        );
        let twice = "VERTEX_SE2 0 0 0 0\nVERTEX_XY 0 1 1\n";
        assert_eq!(
            parse_str(twice).unwrap_err().to_string(),
            "line 2: vertex 0 also on line 1"
        );
    }

    #[test]
    fn manhattan_3500_solves_to_the_reference_chi2() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../data/posegraph/manhattanOlson3500.g2o.gz");
        let mut g2o = read(&path).unwrap();
        assert_eq!((g2o.graph.poses.len(), g2o.edges()), (3500, 5598));
        let report = g2o.graph.solve(&SolveOptions::pose_graph()).unwrap();
        assert!(report.converged, "{report:?}");
        let chi2 = g2o.graph.chi2_measurements();
        assert!((chi2 - 146.0787).abs() < 1e-3, "χ² {chi2}");
    }
}
