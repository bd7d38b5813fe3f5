//! Levenberg–Marquardt on a [`Graph`], with a sparse Cholesky factorisation of the damped
//! normal equations (faer; approximate-minimum-degree ordering, computed once per graph
//! shape) and iteratively reweighted sightings for the robust kernel.

use super::{Graph, Linearised};
use crate::pose::Pose2;
use crate::{Error, Result};
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{Argsort, Pair, SparseColMat, SymbolicSparseColMat, Triplet};
use faer::{Mat, Side};
use nalgebra::{DMatrix, Matrix2, Vector2};
use std::time::Instant;

/// How sightings with large normalised residuals are down-weighted (the other factors are
/// plain least squares). `s = rᵀ Ω r` is a sighting's squared normalised residual.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kernel {
    /// Plain least squares, `ρ(s) = s`.
    None,
    /// Huber with threshold `k` (in standard deviations): `ρ(s) = s` for `s ≤ k²`, else
    /// `2k√s − k²` — quadratic inside, linear outside.
    Huber(f64),
    /// Cauchy with scale `c`: `ρ(s) = c² ln(1 + s / c²)` — a wrong association's pull
    /// fades as it grows.
    Cauchy(f64),
}

impl Kernel {
    /// `ρ(s)`.
    fn cost(self, s: f64) -> f64 {
        match self {
            Self::None => s,
            Self::Huber(k) if s > k * k => 2.0 * k * s.sqrt() - k * k,
            Self::Huber(_) => s,
            Self::Cauchy(c) => c * c * (s / (c * c)).ln_1p(),
        }
    }

    /// `ρ′(s)`: the weight of the sighting in the normal equations.
    fn weight(self, s: f64) -> f64 {
        match self {
            Self::None => 1.0,
            Self::Huber(k) if s > k * k => k / s.sqrt(),
            Self::Huber(_) => 1.0,
            Self::Cauchy(c) => 1.0 / (1.0 + s / (c * c)),
        }
    }
}

/// Settings of [`Graph::solve`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveOptions {
    /// Most iterations (accepted or rejected steps).
    pub max_iterations: usize,
    /// Converged when an accepted step lowers the cost by less than this fraction.
    pub relative_tolerance: f64,
    /// Converged when an accepted step moves no unknown by more than this (metres or
    /// radians): the test that ends a solve whose cost goes to zero.
    pub step_tolerance: f64,
    /// The sightings' robust kernel.
    pub kernel: Kernel,
}

impl Default for SolveOptions {
    fn default() -> Self {
        Self {
            max_iterations: 100,
            relative_tolerance: 1e-9,
            step_tolerance: 1e-10,
            kernel: Kernel::None,
        }
    }
}

/// What a solve did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveReport {
    /// Iterations run (accepted and rejected steps).
    pub iterations: usize,
    /// Robust cost before and after.
    pub initial_cost: f64,
    /// Robust cost after the solve.
    pub final_cost: f64,
    /// Whether the relative tolerance was reached (else the iterations ran out or the
    /// damping could not find a step that lowers the cost).
    pub converged: bool,
    /// Wall time of the solve (s).
    pub seconds: f64,
}

/// The damped normal equations' pieces at one linearisation point.
struct Normal {
    /// Lower triangle of `H` (row ≥ column), duplicates summed by the sparse matrix.
    entries: Vec<Triplet<usize, usize, f64>>,
    gradient: Vec<f64>,
    /// `diag(H)`, for Marquardt's scaling of the damping.
    diagonal: Vec<f64>,
}

impl Normal {
    fn new(n: usize) -> Self {
        Self {
            entries: Vec::new(),
            gradient: vec![0.0; n],
            diagonal: vec![0.0; n],
        }
    }

    /// Adds one factor: residual `r`, Jacobian blocks `(first column, J)` and weight
    /// matrix `w` (`ρ′ Ω`).
    fn add(&mut self, r: &[f64], blocks: &[(usize, DMatrix<f64>)], w: &DMatrix<f64>) {
        let r = nalgebra::DVector::from_column_slice(r);
        let wr = w * &r;
        for (a, (col_a, ja)) in blocks.iter().enumerate() {
            let g = ja.transpose() * &wr;
            for (k, v) in g.iter().enumerate() {
                self.gradient[col_a + k] += v;
            }
            let jw = ja.transpose() * w;
            for (col_b, jb) in &blocks[..=a] {
                let h = &jw * jb;
                for i in 0..h.nrows() {
                    for j in 0..h.ncols() {
                        let (row, col) = (col_a + i, col_b + j);
                        if row >= col {
                            self.entries.push(Triplet::new(row, col, h[(i, j)]));
                            if row == col {
                                self.diagonal[row] += h[(i, j)];
                            }
                        }
                    }
                }
            }
        }
    }
}

/// The sparsity of the damped normal equations — the factors' entries, then the
/// diagonal — with the order that fills it and its symbolic Cholesky factorisation: the
/// same every iteration while the same factors linearise, so built once.
struct Pattern {
    indices: Vec<(usize, usize)>,
    matrix: SymbolicSparseColMat<usize>,
    argsort: Argsort<usize>,
    llt: SymbolicLlt<usize>,
}

impl Pattern {
    /// The pattern of `normal` (with `n` unknowns): `cached` when it still fits, else
    /// built and cached.
    fn reuse_or_build<'a>(
        cached: &'a mut Option<Pattern>,
        normal: &Normal,
        n: usize,
    ) -> Result<&'a Pattern> {
        let indices: Vec<(usize, usize)> = (normal.entries.iter().map(|t| (t.row, t.col)))
            .chain((0..n).map(|i| (i, i)))
            .collect();
        if cached.as_ref().is_some_and(|p| p.indices == indices) {
            return Ok(cached.as_ref().expect("checked"));
        }
        let pairs: Vec<Pair<usize, usize>> = indices
            .iter()
            .map(|&(row, col)| Pair::new(row, col))
            .collect();
        let (matrix, argsort) = SymbolicSparseColMat::try_new_from_indices(n, n, &pairs)
            .map_err(|e| factorisation(format!("{e:?}")))?;
        let llt = SymbolicLlt::try_new(matrix.as_ref(), Side::Lower)
            .map_err(|e| factorisation(format!("{e:?}")))?;
        Ok(cached.insert(Pattern {
            indices,
            matrix,
            argsort,
            llt,
        }))
    }
}

impl Graph {
    /// First column of pose `i` and landmark `k` in the unknowns.
    fn pose_column(&self, i: usize) -> usize {
        3 * i
    }

    fn landmark_column(&self, k: usize) -> usize {
        3 * self.poses.len() + 2 * k
    }

    /// The robust cost `Σ ρ(rᵀ Ω r)` at the current estimates (ρ the identity but for
    /// sightings).
    fn cost(&self, kernel: Kernel) -> f64 {
        let mut cost = 0.0;
        self.each_factor(kernel, |_, r, _, w| cost += w.0 * quadratic(r, w.1));
        cost
    }

    /// Calls `f(blocks, residual, (J blocks), (cost weight ρ(s)/s, Ω), IRLS weight)` for
    /// every factor; see [`Normal::add`].
    fn each_factor(
        &self,
        kernel: Kernel,
        mut f: impl FnMut(Vec<(usize, DMatrix<f64>)>, &[f64], f64, (f64, &DMatrix<f64>)),
    ) {
        let dm3 = |m: &nalgebra::Matrix3<f64>| DMatrix::from_column_slice(3, 3, m.as_slice());
        let dm2 = |m: &nalgebra::Matrix2<f64>| DMatrix::from_column_slice(2, 2, m.as_slice());
        for p in &self.priors {
            if let Linearised::Prior { r, j } = p.linearise(&self.poses[p.pose]) {
                let blocks = vec![(self.pose_column(p.pose), dm3(&j))];
                f(blocks, r.as_slice(), 1.0, (1.0, &dm3(&p.information)));
            }
        }
        for b in &self.betweens {
            let (from, to) = (&self.poses[b.from], &self.poses[b.to]);
            if let Linearised::Between { r, j_from, j_to } = b.linearise(from, to) {
                let blocks = vec![
                    (self.pose_column(b.from), dm3(&j_from)),
                    (self.pose_column(b.to), dm3(&j_to)),
                ];
                f(blocks, r.as_slice(), 1.0, (1.0, &dm3(&b.information)));
            }
        }
        for s in &self.sightings {
            let (pose, landmark) = (&self.poses[s.pose], &self.landmarks[s.landmark]);
            if let Some(Linearised::Sighting {
                r,
                j_pose,
                j_landmark,
            }) = s.linearise(pose, landmark)
            {
                let omega = dm2(&s.information);
                let sq = quadratic(r.as_slice(), &omega);
                let cost_weight = if sq > 0.0 { kernel.cost(sq) / sq } else { 1.0 };
                let blocks = vec![
                    (
                        self.pose_column(s.pose),
                        DMatrix::from_column_slice(2, 3, j_pose.as_slice()),
                    ),
                    (self.landmark_column(s.landmark), dm2(&j_landmark)),
                ];
                f(
                    blocks,
                    r.as_slice(),
                    kernel.weight(sq),
                    (cost_weight, &omega),
                );
            }
        }
    }

    /// The normal equations at the current estimates.
    fn normal(&self, kernel: Kernel) -> Normal {
        let mut normal = Normal::new(self.unknowns());
        self.each_factor(kernel, |blocks, r, weight, (_, omega)| {
            normal.add(r, &blocks, &(omega * weight));
        });
        normal
    }

    /// Applies the step `delta` (ordered as the unknowns) to the estimates.
    fn apply(&mut self, delta: &[f64]) {
        for (i, p) in self.poses.iter_mut().enumerate() {
            let d = &delta[3 * i..3 * i + 3];
            *p = Pose2::new(p.x + d[0], p.y + d[1], p.theta + d[2]);
        }
        let base = 3 * self.poses.len();
        for (k, m) in self.landmarks.iter_mut().enumerate() {
            *m += Vector2::new(delta[base + 2 * k], delta[base + 2 * k + 1]);
        }
    }

    /// Minimises the (robust) cost over every pose and landmark by Levenberg–Marquardt;
    /// see the module documentation. The estimates are the starting point and hold the
    /// solution afterwards.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when the graph has no pose, a factor refers to a missing
    /// variable, or the normal equations cannot be factorised (a variable no factor
    /// constrains).
    ///
    /// # Performance
    /// Per iteration one linearisation (O(factors)) and one sparse Cholesky
    /// factorisation; the poses form a chain and each landmark couples the poses that
    /// saw it, so the fill stays small for maps with few landmarks per pose.
    pub fn solve(&mut self, options: &SolveOptions) -> Result<SolveReport> {
        self.check_indices()?;
        let started = Instant::now();
        let n = self.unknowns();
        let kernel = options.kernel;
        let mut cost = self.cost(kernel);
        let initial_cost = cost;
        let mut lambda = 1e-4;
        let mut pattern: Option<Pattern> = None;
        let (mut iterations, mut converged) = (0, false);
        'outer: while iterations < options.max_iterations {
            let normal = self.normal(kernel);
            let pattern = Pattern::reuse_or_build(&mut pattern, &normal, n)?;
            loop {
                iterations += 1;
                let values: Vec<f64> = (normal.entries.iter().map(|t| t.val))
                    .chain(normal.diagonal.iter().map(|d| lambda * (d + 1e-9)))
                    .collect();
                let h = SparseColMat::new_from_argsort(
                    pattern.matrix.clone(),
                    &pattern.argsort,
                    &values,
                )
                .map_err(|e| factorisation(format!("{e:?}")))?;
                let step = Llt::try_new_with_symbolic(pattern.llt.clone(), h.as_ref(), Side::Lower)
                    .ok()
                    .map(|llt| {
                        let mut rhs = Mat::from_fn(n, 1, |i, _| -normal.gradient[i]);
                        llt.solve_in_place(rhs.as_mut());
                        (0..n).map(|i| rhs[(i, 0)]).collect::<Vec<f64>>()
                    });
                if let Some(delta) = step.filter(|d| d.iter().all(|v| v.is_finite())) {
                    let before = (self.poses.clone(), self.landmarks.clone());
                    self.apply(&delta);
                    let new_cost = self.cost(kernel);
                    if new_cost < cost {
                        let gain = (cost - new_cost) / cost.max(f64::MIN_POSITIVE);
                        cost = new_cost;
                        lambda = (lambda / 3.0).max(1e-12);
                        let largest = delta.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
                        if gain < options.relative_tolerance || largest < options.step_tolerance {
                            converged = true;
                            break 'outer;
                        }
                        continue 'outer;
                    }
                    (self.poses, self.landmarks) = before;
                }
                lambda *= 5.0;
                if lambda > 1e12 || iterations >= options.max_iterations {
                    // No step lowers the cost any more: at a minimum to rounding.
                    converged = lambda > 1e12;
                    break 'outer;
                }
            }
        }
        Ok(SolveReport {
            iterations,
            initial_cost,
            final_cost: cost,
            converged,
            seconds: started.elapsed().as_secs_f64(),
        })
    }

    /// The marginal covariance of every landmark at the current estimates: the 2 × 2
    /// blocks of `H⁻¹` (`H` the Gauss–Newton information with the kernel's weights).
    ///
    /// # Errors
    /// When `H` cannot be factorised (a variable no factor constrains).
    pub fn landmark_covariances(&self, kernel: Kernel) -> Result<Vec<Matrix2<f64>>> {
        self.covariances(kernel)?.marginals()
    }

    /// `H` (the Gauss–Newton information with the kernel's weights) at the current
    /// estimates, factorised once, for the landmark covariances — blocks of `H⁻¹` — that
    /// a caller reads from it.
    ///
    /// # Errors
    /// When `H` cannot be factorised (a variable no factor constrains).
    pub fn covariances(&self, kernel: Kernel) -> Result<Covariances<'_>> {
        self.check_indices()?;
        let n = self.unknowns();
        let normal = self.normal(kernel);
        let mut cached = None;
        let pattern = Pattern::reuse_or_build(&mut cached, &normal, n)?;
        let values: Vec<f64> = (normal.entries.iter().map(|t| t.val))
            .chain(std::iter::repeat_n(0.0, n))
            .collect();
        let h = SparseColMat::new_from_argsort(pattern.matrix.clone(), &pattern.argsort, &values)
            .map_err(|e| factorisation(format!("{e:?}")))?;
        let llt = Llt::try_new_with_symbolic(pattern.llt.clone(), h.as_ref(), Side::Lower)
            .map_err(|e| factorisation(format!("{e:?}")))?;
        Ok(Covariances { graph: self, llt })
    }

    /// Every factor's indices inside the variables.
    fn check_indices(&self) -> Result<()> {
        let (np, nl) = (self.poses.len(), self.landmarks.len());
        let bad = self.priors.iter().any(|p| p.pose >= np)
            || self.betweens.iter().any(|b| b.from >= np || b.to >= np)
            || self
                .sightings
                .iter()
                .any(|s| s.pose >= np || s.landmark >= nl);
        if np == 0 || bad {
            return Err(Error::InvalidInput {
                what: "graph",
                reason: format!("{np} poses, {nl} landmarks: a factor refers to neither"),
            });
        }
        Ok(())
    }
}

/// A graph's factorised information ([`Graph::covariances`]): the covariances of its
/// landmarks, read as blocks of `H⁻¹` by solving for unit columns.
pub struct Covariances<'g> {
    graph: &'g Graph,
    llt: Llt<usize, f64>,
}

impl Covariances<'_> {
    /// Every landmark's marginal covariance, in landmark order.
    ///
    /// # Errors
    /// None in practice (every landmark is in the graph); see [`blocks`](Self::blocks).
    pub fn marginals(&self) -> Result<Vec<Matrix2<f64>>> {
        let diagonal: Vec<(usize, usize)> =
            (0..self.graph.landmarks.len()).map(|k| (k, k)).collect();
        self.blocks(&diagonal)
    }

    /// The covariance `Cov(m_a, m_b)` of each pair of landmarks `(a, b)`: the 2 × 2 block
    /// of `H⁻¹` at `a`'s rows and `b`'s columns, by solving for `b`'s unit columns, 64 at
    /// a time. `(k, k)` is `k`'s marginal (made exactly symmetric).
    ///
    /// # Errors
    /// When a pair names a landmark the graph does not have.
    ///
    /// # Performance
    /// One solve per 32 distinct second landmarks.
    pub fn blocks(&self, pairs: &[(usize, usize)]) -> Result<Vec<Matrix2<f64>>> {
        let graph = self.graph;
        if pairs
            .iter()
            .any(|&(a, b)| a.max(b) >= graph.landmarks.len())
        {
            return Err(Error::InvalidInput {
                what: "landmark covariance",
                reason: format!("a pair outside the {} landmarks", graph.landmarks.len()),
            });
        }
        let n = graph.unknowns();
        let mut solved: Vec<usize> = pairs.iter().map(|&(_, b)| b).collect();
        solved.sort_unstable();
        solved.dedup();
        let mut out = vec![Matrix2::zeros(); pairs.len()];
        for chunk in solved.chunks(32) {
            let columns: Vec<usize> = (chunk.iter())
                .flat_map(|&k| {
                    let c = graph.landmark_column(k);
                    [c, c + 1]
                })
                .collect();
            let mut rhs = Mat::from_fn(n, columns.len(), |i, j| {
                f64::from(u8::from(i == columns[j]))
            });
            self.llt.solve_in_place(rhs.as_mut());
            for (block, &(a, b)) in out.iter_mut().zip(pairs) {
                let Ok(at) = chunk.binary_search(&b) else {
                    continue;
                };
                let row = graph.landmark_column(a);
                *block = Matrix2::from_fn(|i, j| rhs[(row + i, 2 * at + j)]);
                if a == b {
                    *block = 0.5 * (*block + block.transpose());
                }
            }
        }
        Ok(out)
    }
}

/// `rᵀ Ω r`.
fn quadratic(r: &[f64], omega: &DMatrix<f64>) -> f64 {
    let r = nalgebra::DVector::from_column_slice(r);
    (r.transpose() * omega * &r)[0]
}

fn factorisation(reason: String) -> Error {
    Error::InvalidInput {
        what: "graph normal equations",
        reason,
    }
}
