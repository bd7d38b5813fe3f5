//! Standard test functions for the optimisers, exactly as in
//! `optimizer-reference/funcs.py` (Yao et al. 1999 / GWO-paper ranges): Sphere, Rastrigin,
//! Rosenbrock and Ackley, unshifted (optimum at the centre of the box, or at 1 for
//! Rosenbrock) and shifted off-centre to expose a pull toward the origin.
//!
//! The shifted function is `f(x − o)` with `o` drawn once per (function, dimension) by numpy;
//! the vectors for 3 and 10 dimensions (the reference tables) are embedded below.

use super::{Bounds, Problem};
use crate::{Error, Result};
use std::f64::consts::{E, TAU};

/// One of the four test functions (value 0 at the optimum).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TestFunction {
    /// `Σ z²`, box ±100.
    Sphere,
    /// `10 D + Σ (z² − 10 cos 2πz)`, box ±5.12.
    Rastrigin,
    /// `Σ 100 (z_{i+1} − z_i²)² + (z_i − 1)²`, box ±30, optimum at z = 1.
    Rosenbrock,
    /// `−20 exp(−0.2 √(Σz²/D)) − exp(Σ cos(2πz)/D) + 20 + e`, clamped at 0, box ±32.
    Ackley,
}

impl TestFunction {
    /// The four, in the order of the reference tables' rows.
    pub const ALL: [Self; 4] = [
        Self::Ackley,
        Self::Rastrigin,
        Self::Rosenbrock,
        Self::Sphere,
    ];

    /// The name used by `funcs.py` (and to derive the shift's seed).
    pub fn name(self) -> &'static str {
        match self {
            Self::Sphere => "sphere",
            Self::Rastrigin => "rastrigin",
            Self::Rosenbrock => "rosenbrock",
            Self::Ackley => "ackley",
        }
    }

    /// `ub` of `funcs.py`: the box is `[−ub, ub]` in every dimension.
    pub fn half_width(self) -> f64 {
        match self {
            Self::Sphere => 100.0,
            Self::Rastrigin => 5.12,
            Self::Rosenbrock => 30.0,
            Self::Ackley => 32.0,
        }
    }

    /// `f(z)`.
    pub fn value(self, z: &[f64]) -> f64 {
        self.value_of(z.iter().copied())
    }

    /// `f` of the coordinates `z` yields, without collecting them (the shifted problem passes
    /// `x − o` lazily, so an evaluation allocates nothing).
    fn value_of(self, z: impl Iterator<Item = f64> + Clone) -> f64 {
        match self {
            Self::Sphere => z.map(|v| v * v).sum(),
            Self::Rastrigin => {
                let (n, sum) = z.fold((0.0, 0.0), |(n, s), v| {
                    (n + 1.0, s + v * v - 10.0 * (TAU * v).cos())
                });
                10.0 * n + sum
            }
            Self::Rosenbrock => z
                .clone()
                .zip(z.skip(1))
                .map(|(a, b)| 100.0 * (b - a * a).powi(2) + (a - 1.0).powi(2))
                .sum(),
            Self::Ackley => {
                let (mut n, mut squares, mut cosines) = (0.0, 0.0, 0.0);
                for v in z {
                    n += 1.0;
                    squares += v * v;
                    cosines += (TAU * v).cos();
                }
                let value =
                    -20.0 * (-0.2 * (squares / n).sqrt()).exp() - (cosines / n).exp() + 20.0 + E;
                // funcs.py clamps the −4e-16 round-off at the optimum (BA's I^a needs f ≥ 0).
                value.max(0.0)
            }
        }
    }
}

/// The shift `o` of `funcs.py` for `function` in `dim` dimensions, where embedded (3 and 10).
///
/// Produced by (numpy 2.4.6):
///
/// ```python
/// import numpy as np
/// for name, ub in {"sphere": 100.0, "rastrigin": 5.12, "rosenbrock": 30.0, "ackley": 32.0}.items():
///     for dim in (3, 10):
///         rng = np.random.default_rng(sum(map(ord, name)) * 1000 + dim)
///         print(name, dim, [repr(float(v)) for v in rng.uniform(-0.5 * ub, 0.5 * ub, dim)])
/// ```
pub fn shift(function: TestFunction, dim: usize) -> Option<&'static [f64]> {
    use TestFunction::*;
    Some(match (function, dim) {
        (Sphere, 3) => &[18.209868705535996, -33.04090177258337, -15.619897732605637],
        (Sphere, 10) => &[
            9.783603424398905,
            10.310321190555769,
            49.35587668309326,
            38.53303711210518,
            -20.068669509506478,
            25.499029382095102,
            39.96588505526924,
            21.533163944364063,
            -44.465832825428706,
            -11.135644734778168,
        ],
        (Rastrigin, 3) => &[
            -1.4469206599089899,
            -0.7782794147689083,
            -0.4447875314973042,
        ],
        (Rastrigin, 10) => &[
            -1.1216482481355274,
            -1.588845514164579,
            -1.549564087044546,
            -2.33679930676565,
            0.22016328376103766,
            -0.6591028647572064,
            2.2017017712211575,
            2.0786613498736783,
            1.6604171298916008,
            0.4215092856212004,
        ],
        (Rosenbrock, 3) => &[0.8167701805132186, 0.8364892334464553, 8.132827671010624],
        (Rosenbrock, 10) => &[
            -10.808048330867964,
            -7.545329978700566,
            -6.437193958298193,
            2.808821763223513,
            14.284183408946298,
            5.290717959220341,
            -6.847893920295798,
            12.900095727674351,
            3.9019746332346408,
            1.0233416374228739,
        ],
        (Ackley, 3) => &[15.613613129824614, -0.7182408301549401, 7.583645305100511],
        (Ackley, 10) => &[
            11.66755184297968,
            14.004973465251261,
            -6.070194993674068,
            12.718084415635293,
            -8.781514567314051,
            3.414725023904225,
            -13.491590101286995,
            -5.586132466114041,
            -15.072003813459844,
            0.0007836573006443359,
        ],
        _ => return None,
    })
}

/// A test function as a [`Problem`] on its box `[−ub, ub]^D`, optionally shifted.
#[derive(Debug, Clone, PartialEq)]
pub struct Benchmark {
    function: TestFunction,
    bounds: Bounds,
    /// `o`; all zeros when unshifted (`x − 0.0` is exactly `x`).
    shift: Vec<f64>,
    shifted: bool,
}

impl Benchmark {
    /// `function` in `dim` dimensions, shifted by [`shift`] when `shifted`.
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] when `dim` is 0, below 2 for Rosenbrock, or a shift is
    /// asked for a dimension that has none embedded.
    pub fn new(function: TestFunction, dim: usize, shifted: bool) -> Result<Self> {
        let min_dim = if function == TestFunction::Rosenbrock {
            2
        } else {
            1
        };
        if dim < min_dim {
            return Err(Error::InvalidParameter {
                name: "dim",
                reason: format!("{} needs at least {min_dim} dimensions", function.name()),
            });
        }
        let shift = if shifted {
            self::shift(function, dim)
                .ok_or_else(|| Error::InvalidParameter {
                    name: "dim",
                    reason: format!(
                        "no shift embedded for {} in {dim} dimensions",
                        function.name()
                    ),
                })?
                .to_vec()
        } else {
            vec![0.0; dim]
        };
        let ub = function.half_width();
        Ok(Self {
            function,
            bounds: Bounds::cube(dim, -ub, ub)?,
            shift,
            shifted,
        })
    }

    /// The function.
    pub fn function(&self) -> TestFunction {
        self.function
    }

    /// Whether the optimum is moved off-centre.
    pub fn is_shifted(&self) -> bool {
        self.shifted
    }
}

impl Problem for Benchmark {
    fn bounds(&self) -> &Bounds {
        &self.bounds
    }

    /// `f(x − o)`; the member index is ignored.
    fn fitness(&self, _member: usize, x: &[f64]) -> f64 {
        self.function
            .value_of(x.iter().zip(&self.shift).map(|(v, o)| v - o))
    }

    /// Tens of nanoseconds per evaluation: cheaper than a rayon task.
    fn parallel(&self) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Python: `x10 = np.linspace(-2.2, 3.1, 10)`.
    const X10: [f64; 10] = [
        -2.2,
        -1.6111111111111112,
        -1.0222222222222221,
        -0.4333333333333331,
        0.1555555555555559,
        0.7444444444444449,
        1.333333333333334,
        1.9222222222222234,
        2.511111111111112,
        3.1,
    ];
    const X3: [f64; 3] = [0.3, -1.2, 2.5];

    #[test]
    fn values_match_funcs_py() {
        // Python: f(x) and make_objective(name, dim, True)[0](x) from funcs.py.
        let expected = [
            (
                TestFunction::Sphere,
                7.78,
                1662.9371165809273,
                30.6351851851852,
                9650.416859487948,
            ),
            (
                TestFunction::Rastrigin,
                47.78,
                41.50517991965847,
                127.25129412421282,
                83.78300450848108,
            ),
            (
                TestFunction::Rosenbrock,
                284.1,
                10107.217844829269,
                6998.911806127119,
                6997757.065759876,
            ),
            (
                TestFunction::Ackley,
                7.508896840376369,
                18.775654198749034,
                7.5909222543321455,
                19.563172345221247,
            ),
        ];
        for (function, plain3, shifted3, plain10, shifted10) in expected {
            for (x, want, shifted) in [
                (&X3[..], plain3, false),
                (&X3[..], shifted3, true),
                (&X10[..], plain10, false),
                (&X10[..], shifted10, true),
            ] {
                let problem = Benchmark::new(function, x.len(), shifted).unwrap();
                let got = problem.fitness(0, x);
                assert!(
                    (got - want).abs() <= 1e-12 * want.abs(),
                    "{function:?} {x:?}: {got} != {want}"
                );
            }
        }
    }

    #[test]
    fn optimum_is_zero_at_the_centre_or_at_the_shift() {
        for function in TestFunction::ALL {
            let at = if function == TestFunction::Rosenbrock {
                1.0
            } else {
                0.0
            };
            for dim in [3, 10] {
                let plain = Benchmark::new(function, dim, false).unwrap();
                // Ackley's round-off leaves 4.4e-16, as in the reference tables.
                assert!(plain.fitness(0, &vec![at; dim]) < 1e-15, "{function:?}");
                let shifted = Benchmark::new(function, dim, true).unwrap();
                let optimum: Vec<f64> = shift(function, dim)
                    .unwrap()
                    .iter()
                    .map(|o| o + at)
                    .collect();
                assert!(shifted.bounds().contains(&optimum));
                assert!(shifted.fitness(0, &optimum) < 1e-12, "{function:?} {dim}");
            }
        }
    }

    #[test]
    fn shifts_exist_only_where_embedded() {
        assert!(Benchmark::new(TestFunction::Sphere, 5, true).is_err());
        assert!(Benchmark::new(TestFunction::Sphere, 5, false).is_ok());
        assert!(Benchmark::new(TestFunction::Rosenbrock, 1, false).is_err());
    }
}
