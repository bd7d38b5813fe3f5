//! The normal equations `H δ = −g` of a [`Graph`] in a sparse column layout built once
//! per graph shape: the non-zero blocks of `H`'s lower triangle (3 × 3 between poses,
//! 2 × 2 between landmarks, 2 × 3 between a landmark and a pose), where each factor's
//! blocks land in the value array, and the symbolic Cholesky factorisation with its
//! fill-reducing order (faer, approximate minimum degree). An iteration then only writes
//! numbers: every factor is linearised into fixed-size blocks and added at its
//! precomputed slots — no heap matrix per factor, no triplets, no sorting — and the
//! numeric factorisation reuses the symbolic one and one scratch buffer.

use super::solve::{Damping, Kernel, PoseUpdate};
use super::{Graph, Linearised};
use crate::{Error, Result};
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::perm::PermRef;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::amd;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par, Side};
use nalgebra::{Matrix2, SMatrix, SVector};

/// The value-array index of each column's first entry in one block (3 columns at most).
type Columns = [usize; 3];

/// faer's switch between its simplicial and supernodal factorisations, as a fraction of
/// its default: supernodal when the factorisation's flops per factor entry pass
/// `40 ×` this. With each variable's unknowns kept together the supernodal kernels pay
/// from a lower ratio than faer's default assumes: Manhattan 3500 (about 17) factorises
/// in 3.3 ms supernodal against 4.7 ms simplicial, MIT-b (about 4) the same either way.
const SUPERNODAL_THRESHOLD: f64 = 0.25;

/// Where a two-variable factor's three blocks of `H` sit.
#[derive(Debug, Clone, Copy)]
struct PairSlots {
    /// The first variable's diagonal block.
    first: Columns,
    /// The second variable's diagonal block.
    second: Columns,
    /// The off-diagonal block, in the columns of whichever variable comes first in the
    /// unknowns.
    cross: Columns,
    /// Whether the first variable comes later (its rows hold the off-diagonal block).
    first_is_row: bool,
    /// Both variables the same (a factor from a pose to itself).
    same: bool,
}

/// The normal equations of one graph shape; see the module documentation.
pub(crate) struct System {
    n: usize,
    /// Lower triangle of `H`, rows sorted in each column, the diagonal first.
    pattern: SymbolicSparseColMat<usize>,
    priors: Vec<Columns>,
    landmark_priors: Vec<Columns>,
    betweens: Vec<PairSlots>,
    sightings: Vec<PairSlots>,
    offsets: Vec<PairSlots>,
    symbolic: SymbolicCholesky<usize>,
    /// `H`'s values at the last linearisation (no damping).
    h: Vec<f64>,
    /// `g = Σ Jᵀ W r` at the last linearisation.
    gradient: Vec<f64>,
    damped: Vec<f64>,
    factor: Vec<f64>,
    buffer: MemBuffer,
    /// Each pose's `(sin θ, cos θ)` at the last linearisation, for the exponential update.
    turns: Vec<(f64, f64)>,
}

/// The variables' layout in the unknowns: poses first (3 each), then landmarks (2 each).
#[derive(Clone, Copy)]
struct Layout {
    poses: usize,
}

impl Layout {
    fn start(self, v: usize) -> usize {
        if v < self.poses {
            3 * v
        } else {
            3 * self.poses + 2 * (v - self.poses)
        }
    }

    fn dim(self, v: usize) -> usize {
        if v < self.poses { 3 } else { 2 }
    }
}

impl System {
    /// The structure of `graph`'s normal equations and its symbolic factorisation. The
    /// factors' indices must be in range (`Graph::check_indices`).
    pub(crate) fn new(graph: &Graph) -> Result<Self> {
        let layout = Layout {
            poses: graph.poses.len(),
        };
        let variables = graph.poses.len() + graph.landmarks.len();
        let n = graph.unknowns();
        let landmark = |k: usize| layout.poses + k;
        // Each variable's later neighbours: the row blocks of its columns.
        let mut below: Vec<Vec<usize>> = vec![Vec::new(); variables];
        let mut link = |a: usize, b: usize| {
            if a != b {
                below[a.min(b)].push(a.max(b));
            }
        };
        for b in &graph.betweens {
            link(b.from, b.to);
        }
        for s in &graph.sightings {
            link(s.pose, landmark(s.landmark));
        }
        for o in &graph.offsets {
            link(o.pose, landmark(o.landmark));
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        // Rows of each neighbour block before it in its column (past the diagonal block).
        let mut prefix: Vec<Vec<usize>> = Vec::with_capacity(variables);
        for (v, rows) in below.iter_mut().enumerate() {
            rows.sort_unstable();
            rows.dedup();
            let (start, dim) = (layout.start(v), layout.dim(v));
            let mut before = Vec::with_capacity(rows.len());
            let mut sum = 0;
            for &u in rows.iter() {
                before.push(sum);
                sum += layout.dim(u);
            }
            prefix.push(before);
            for j in 0..dim {
                row_idx.extend(start + j..start + dim);
                for &u in rows.iter() {
                    row_idx.extend(layout.start(u)..layout.start(u) + layout.dim(u));
                }
                col_ptr.push(row_idx.len());
            }
        }
        let diagonal = |v: usize| -> Columns {
            let start = layout.start(v);
            std::array::from_fn(|j| {
                if j < layout.dim(v) {
                    col_ptr[start + j]
                } else {
                    0
                }
            })
        };
        let pair = |a: usize, b: usize| -> PairSlots {
            let (col, row) = (a.min(b), a.max(b));
            let mut cross = [0; 3];
            if a != b {
                let at = below[col].binary_search(&row).expect("linked");
                let (start, dim) = (layout.start(col), layout.dim(col));
                for (j, slot) in cross.iter_mut().enumerate().take(dim) {
                    *slot = col_ptr[start + j] + (dim - j) + prefix[col][at];
                }
            }
            PairSlots {
                first: diagonal(a),
                second: diagonal(b),
                cross,
                first_is_row: a > b,
                same: a == b,
            }
        };
        let priors = graph.priors.iter().map(|p| diagonal(p.pose)).collect();
        let landmark_priors = (graph.landmark_priors.iter())
            .map(|p| diagonal(landmark(p.landmark)))
            .collect();
        let betweens = graph.betweens.iter().map(|b| pair(b.from, b.to)).collect();
        let sightings = (graph.sightings.iter())
            .map(|s| pair(s.pose, landmark(s.landmark)))
            .collect();
        let offsets = (graph.offsets.iter())
            .map(|o| pair(o.pose, landmark(o.landmark)))
            .collect();
        let nnz = row_idx.len();
        let pattern = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        let (forward, inverse) = block_order(&below, layout)?;
        let symbolic = factorize_symbolic_cholesky(
            pattern.as_ref(),
            Side::Lower,
            SymmetricOrdering::Custom(PermRef::new_checked(&forward, &inverse, n)),
            CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: SupernodalThreshold(SUPERNODAL_THRESHOLD),
                ..Default::default()
            },
        )
        .map_err(|e| factorisation(format!("{e:?}")))?;
        let scratch = StackReq::any_of(&[
            symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
        ]);
        Ok(Self {
            n,
            factor: vec![0.0; symbolic.len_val()],
            pattern,
            priors,
            landmark_priors,
            betweens,
            sightings,
            offsets,
            symbolic,
            h: vec![0.0; nnz],
            gradient: vec![0.0; n],
            damped: vec![0.0; nnz],
            buffer: MemBuffer::new(scratch),
            turns: Vec::new(),
        })
    }

    /// Linearises every factor of `graph` (its shape the one this system was built for)
    /// at the current estimates into `H` and `g`, sightings and offsets weighted by
    /// `kernel`'s `ρ′`, the poses' columns in the coordinates of `update`.
    pub(crate) fn linearise(&mut self, graph: &Graph, kernel: Kernel, update: PoseUpdate) {
        let layout = Layout {
            poses: graph.poses.len(),
        };
        self.h.fill(0.0);
        self.gradient.fill(0.0);
        self.turns.clear();
        if update == PoseUpdate::Exponential {
            self.turns
                .extend(graph.poses.iter().map(|p| p.theta.sin_cos()));
        }
        let turns = &self.turns;
        let (h, g) = (&mut self.h, &mut self.gradient);
        for (p, slots) in graph.priors.iter().zip(&self.priors) {
            if let Linearised::Prior { r, mut j } = p.linearise(&graph.poses[p.pose]) {
                turn(turns, p.pose, &mut j);
                let at = layout.start(p.pose);
                add_single(h, g, slots, at, (&r, &j), &p.information);
            }
        }
        for (p, slots) in graph.landmark_priors.iter().zip(&self.landmark_priors) {
            let r = graph.landmarks[p.landmark] - p.mean;
            let at = layout.start(layout.poses + p.landmark);
            add_single(h, g, slots, at, (&r, &Matrix2::identity()), &p.information);
        }
        for (b, slots) in graph.betweens.iter().zip(&self.betweens) {
            let (r, mut j_from, mut j_to) = b.jacobians(&graph.poses[b.from], &graph.poses[b.to]);
            turn(turns, b.from, &mut j_from);
            turn(turns, b.to, &mut j_to);
            if slots.same {
                // A factor from a pose to itself: one variable.
                let (j, at) = (j_from + j_to, layout.start(b.from));
                add_single(h, g, &slots.first, at, (&r, &j), &b.information);
            } else {
                let at = (layout.start(b.from), layout.start(b.to));
                add_pair(h, g, slots, at, (&r, &j_from, &j_to), &b.information);
            }
        }
        for (s, slots) in graph.sightings.iter().zip(&self.sightings) {
            let (pose, landmark) = (&graph.poses[s.pose], &graph.landmarks[s.landmark]);
            if let Some(Linearised::Sighting {
                r,
                mut j_pose,
                j_landmark,
            }) = s.linearise(pose, landmark)
            {
                turn(turns, s.pose, &mut j_pose);
                let w = s.information * kernel.weight((r.transpose() * s.information * r)[0]);
                let at = (
                    layout.start(s.pose),
                    layout.start(layout.poses + s.landmark),
                );
                add_pair(h, g, slots, at, (&r, &j_pose, &j_landmark), &w);
            }
        }
        for (o, slots) in graph.offsets.iter().zip(&self.offsets) {
            let (pose, landmark) = (&graph.poses[o.pose], &graph.landmarks[o.landmark]);
            let (r, mut j_pose, j_landmark) = o.jacobians(pose, landmark);
            turn(turns, o.pose, &mut j_pose);
            let w = o.information * kernel.weight((r.transpose() * o.information * r)[0]);
            let at = (
                layout.start(o.pose),
                layout.start(layout.poses + o.landmark),
            );
            add_pair(h, g, slots, at, (&r, &j_pose, &j_landmark), &w);
        }
    }

    /// The Levenberg–Marquardt step `δ = −(H + λ D)⁻¹ g` into `step`, `D` as `damping`
    /// says; false when the damped matrix is not positive definite or the step is not
    /// finite.
    pub(crate) fn step(&mut self, damping: Damping, lambda: f64, step: &mut [f64]) -> bool {
        self.damped.copy_from_slice(&self.h);
        // The diagonal is each column's first entry.
        for &d in &self.pattern.col_ptr()[..self.n] {
            self.damped[d] += match damping {
                Damping::Marquardt => lambda * (self.h[d] + 1e-9),
                Damping::Levenberg => lambda,
            };
        }
        for (s, g) in step.iter_mut().zip(&self.gradient) {
            *s = -g;
        }
        let matrix = SparseColMatRef::new(self.pattern.as_ref(), &self.damped);
        let stack = MemStack::new(&mut self.buffer);
        let Ok(llt) = self.symbolic.factorize_numeric_llt(
            &mut self.factor,
            matrix,
            Side::Lower,
            Default::default(),
            Par::Seq,
            stack,
            Default::default(),
        ) else {
            return false;
        };
        let rhs = MatMut::from_column_major_slice_mut(step, self.n, 1);
        llt.solve_in_place_with_conj(Conj::No, rhs, Par::Seq, MemStack::new(&mut self.buffer));
        step.iter().all(|v| v.is_finite())
    }

    /// The decrease of the cost `Σ rᵀ W r` the linearised model predicts for `step`, the
    /// last [`step`](Self::step)'s solution: `−2 gᵀδ − δᵀ H δ`, which the damped system
    /// `(H + λ D) δ = −g` turns into `−gᵀδ + λ δᵀ D δ` (never negative).
    pub(crate) fn predicted_decrease(&self, step: &[f64]) -> f64 {
        let along: f64 = step.iter().zip(&self.gradient).map(|(s, g)| s * g).sum();
        let damping: f64 = (self.pattern.col_ptr()[..self.n].iter())
            .zip(step)
            .map(|(&d, s)| (self.damped[d] - self.h[d]) * s * s)
            .sum();
        damping - along
    }

    /// Factorises the undamped `H` of the last linearisation, for solves against it
    /// ([`solve_in_place`](Self::solve_in_place)).
    ///
    /// # Errors
    /// When `H` is not positive definite (a variable no factor constrains).
    pub(crate) fn factorise(&mut self) -> Result<()> {
        let matrix = SparseColMatRef::new(self.pattern.as_ref(), &self.h);
        self.symbolic
            .factorize_numeric_llt(
                &mut self.factor,
                matrix,
                Side::Lower,
                Default::default(),
                Par::Seq,
                MemStack::new(&mut self.buffer),
                Default::default(),
            )
            .map(|_| ())
            .map_err(|e| factorisation(format!("{e:?}")))
    }

    /// Solves `H X = B` in place for the columns of `rhs` with the factorisation of the
    /// last [`factorise`](Self::factorise).
    pub(crate) fn solve_in_place(&self, rhs: MatMut<'_, f64>) {
        let req = self
            .symbolic
            .solve_in_place_scratch::<f64>(rhs.ncols(), Par::Seq);
        let mut buffer = MemBuffer::new(req);
        LltRef::new(&self.symbolic, &self.factor).solve_in_place_with_conj(
            Conj::No,
            rhs,
            Par::Seq,
            MemStack::new(&mut buffer),
        );
    }
}

/// A Jacobian's three pose columns, for the exponential update's change of coordinates.
trait PoseColumns {
    /// `J ← J · [[c, −s, 0], [s, c, 0], [0, 0, 1]]`: a step in the pose's frame.
    fn rotate(&mut self, s: f64, c: f64);
}

impl<const R: usize> PoseColumns for SMatrix<f64, R, 3> {
    fn rotate(&mut self, s: f64, c: f64) {
        for i in 0..R {
            let (a, b) = (self[(i, 0)], self[(i, 1)]);
            self[(i, 0)] = c * a + s * b;
            self[(i, 1)] = c * b - s * a;
        }
    }
}

/// `J ← J · ∂(X ⊕ ξ)/∂ξ` for pose `i` when `turns` holds the poses' headings (the
/// exponential update), else `J` as it is.
fn turn<J: PoseColumns>(turns: &[(f64, f64)], i: usize, j: &mut J) {
    if let Some(&(s, c)) = turns.get(i) {
        j.rotate(s, c);
    }
}

/// The fill-reducing order of the unknowns: approximate minimum degree on the graph of
/// the variables (a third the size of the unknowns' for a pose graph), each variable's
/// unknowns kept together — so the factor's supernodes follow the blocks. Returns the
/// permutation and its inverse.
fn block_order(below: &[Vec<usize>], layout: Layout) -> Result<(Vec<usize>, Vec<usize>)> {
    let variables = below.len();
    let mut col_ptr = Vec::with_capacity(variables + 1);
    let mut row_idx = Vec::new();
    col_ptr.push(0);
    for (v, rows) in below.iter().enumerate() {
        row_idx.push(v);
        row_idx.extend_from_slice(rows);
        col_ptr.push(row_idx.len());
    }
    let nnz = row_idx.len();
    let graph = SymbolicSparseColMat::new_checked(variables, variables, col_ptr, None, row_idx);
    let (mut order, mut inverse) = (vec![0; variables], vec![0; variables]);
    let mut buffer = MemBuffer::new(amd::order_scratch::<usize>(variables, nnz));
    amd::order(
        &mut order,
        &mut inverse,
        graph.as_ref(),
        Default::default(),
        MemStack::new(&mut buffer),
    )
    .map_err(|e| factorisation(format!("{e:?}")))?;
    let mut forward = Vec::with_capacity(layout.start(variables));
    for &v in &order {
        forward.extend(layout.start(v)..layout.start(v) + layout.dim(v));
    }
    let mut inverse = vec![0; forward.len()];
    for (i, &f) in forward.iter().enumerate() {
        inverse[f] = i;
    }
    Ok((forward, inverse))
}

/// Adds the lower triangle of a diagonal block `m` at `slots`.
fn add_diagonal<const D: usize>(h: &mut [f64], slots: &Columns, m: &SMatrix<f64, D, D>) {
    for j in 0..D {
        for i in j..D {
            h[slots[j] + i - j] += m[(i, j)];
        }
    }
}

/// Adds an off-diagonal block `m` (rows below the diagonal) at `slots`.
fn add_block<const R: usize, const C: usize>(
    h: &mut [f64],
    slots: &Columns,
    m: &SMatrix<f64, R, C>,
) {
    for j in 0..C {
        for i in 0..R {
            h[slots[j] + i] += m[(i, j)];
        }
    }
}

/// Adds `v` to the gradient from unknown `at` on.
fn add_gradient<const D: usize>(g: &mut [f64], at: usize, v: &SVector<f64, D>) {
    for (k, x) in v.iter().enumerate() {
        g[at + k] += x;
    }
}

/// Adds one two-variable factor — residual `r`, Jacobians `ja`, `jb`, weight `w` — to `H`
/// and `g`; `at` are the variables' first unknowns.
fn add_pair<const R: usize, const A: usize, const B: usize>(
    h: &mut [f64],
    g: &mut [f64],
    slots: &PairSlots,
    at: (usize, usize),
    (r, ja, jb): (&SVector<f64, R>, &SMatrix<f64, R, A>, &SMatrix<f64, R, B>),
    w: &SMatrix<f64, R, R>,
) {
    let wr = w * r;
    let (jwa, jwb) = (ja.transpose() * w, jb.transpose() * w);
    add_diagonal(h, &slots.first, &(jwa * ja));
    add_diagonal(h, &slots.second, &(jwb * jb));
    if slots.first_is_row {
        add_block(h, &slots.cross, &(jwa * jb));
    } else {
        add_block(h, &slots.cross, &(jwb * ja));
    }
    add_gradient(g, at.0, &(ja.transpose() * wr));
    add_gradient(g, at.1, &(jb.transpose() * wr));
}

/// Adds one single-variable factor — residual `r`, Jacobian `j`, weight `w` — to `H` and
/// `g`; `at` is the variable's first unknown.
fn add_single<const R: usize, const D: usize>(
    h: &mut [f64],
    g: &mut [f64],
    slots: &Columns,
    at: usize,
    (r, j): (&SVector<f64, R>, &SMatrix<f64, R, D>),
    w: &SMatrix<f64, R, R>,
) {
    let wr = w * r;
    add_diagonal(h, slots, &(j.transpose() * w * j));
    add_gradient(g, at, &(j.transpose() * wr));
}

fn factorisation(reason: String) -> Error {
    Error::InvalidInput {
        what: "graph normal equations",
        reason,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::{Kernel, Prior};
    use crate::pose::Pose2;
    use nalgebra::{Matrix3, Vector3};

    /// With linear residuals (priors, the additive update) the cost is the model, so the
    /// predicted decrease is the decrease a step makes, for any damping.
    #[test]
    fn predicted_decrease_is_the_decrease_of_a_quadratic_cost() {
        let information = Matrix3::new(4.0, 1.0, 0.0, 1.0, 3.0, 0.5, 0.0, 0.5, 2.0);
        let mut graph = Graph::default();
        graph.add_pose(Pose2::new(1.0, -2.0, 0.3));
        graph.add_pose(Pose2::new(0.5, 0.5, -0.2));
        for (pose, mean) in [(0, Pose2::new(0.2, 0.1, 0.1)), (1, Pose2::default())] {
            graph.priors.push(Prior {
                pose,
                mean,
                information,
            });
        }
        let cost = |poses: &[Pose2]| -> f64 {
            (graph.priors.iter())
                .map(|p| {
                    let (x, m) = (poses[p.pose], p.mean);
                    let r = Vector3::new(x.x - m.x, x.y - m.y, x.theta - m.theta);
                    (r.transpose() * p.information * r)[0]
                })
                .sum()
        };
        let mut system = System::new(&graph).unwrap();
        system.linearise(&graph, Kernel::None, PoseUpdate::Additive);
        for (damping, lambda) in [(Damping::Marquardt, 0.0), (Damping::Levenberg, 0.7)] {
            let mut step = vec![0.0; 6];
            assert!(system.step(damping, lambda, &mut step));
            let moved: Vec<Pose2> = (graph.poses.iter().zip(step.chunks_exact(3)))
                .map(|(p, d)| Pose2::new(p.x + d[0], p.y + d[1], p.theta + d[2]))
                .collect();
            let actual = cost(&graph.poses) - cost(&moved);
            let predicted = system.predicted_decrease(&step);
            assert!(actual > 0.1, "{actual}");
            assert!(
                (predicted - actual).abs() < 1e-9 * actual,
                "{predicted} against {actual}"
            );
        }
    }
}
