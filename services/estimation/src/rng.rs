//! Seeded random streams.
//!
//! Every random draw of the estimator comes from a [`SimRng`] built from an explicit seed.
//! Work that may run on several threads (per particle) draws from its own stream, derived
//! from the run's seed and labels such as (step, particle index), so the numbers do not
//! depend on which thread ran which particle.

use rand::SeedableRng;

/// The one generator type of the project: a named, portable algorithm (unlike `StdRng`,
/// whose algorithm may change between rand releases).
pub type SimRng = rand::rngs::Xoshiro256PlusPlus;

/// A generator seeded with `seed`.
pub fn seeded(seed: u64) -> SimRng {
    SimRng::seed_from_u64(seed)
}

/// An independent stream for `labels` (for example `[step, particle]`) under `seed`.
///
/// The labels are mixed with SplitMix64, so nearby labels give unrelated streams.
pub fn stream(seed: u64, labels: &[u64]) -> SimRng {
    Streams::new(seed, labels).stream(&[])
}

/// The streams whose labels start with the same labels under one seed, with that common
/// part mixed once: `Streams::new(seed, &[step]).stream(&[i, purpose])` is
/// `stream(seed, &[step, i, purpose])`. A step's per-particle streams share their seed and
/// step, so setting up N of them mixes those once instead of N times.
#[derive(Debug, Clone, Copy)]
pub struct Streams {
    mixed: u64,
}

impl Streams {
    /// The streams under `seed` whose labels begin with `labels`.
    pub fn new(seed: u64, labels: &[u64]) -> Self {
        Self {
            mixed: mix(splitmix64(seed), labels),
        }
    }

    /// The stream whose labels continue with `labels`.
    pub fn stream(&self, labels: &[u64]) -> SimRng {
        SimRng::seed_from_u64(mix(self.mixed, labels))
    }
}

/// Mixes `labels` into the state `h`, one after the other.
fn mix(mut h: u64, labels: &[u64]) -> u64 {
    for &label in labels {
        h = splitmix64(h ^ splitmix64(label.wrapping_add(0x9E37_79B9_7F4A_7C15)));
    }
    h
}

/// SplitMix64 finaliser (Steele, Lea, Flood 2014): a bijective 64-bit mixer.
fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::RngExt;

    #[test]
    fn same_seed_gives_same_numbers() {
        let a: Vec<f64> = (0..5)
            .map(|_| 0.0)
            .scan(seeded(7), |r, _| Some(r.random()))
            .collect();
        let b: Vec<f64> = (0..5)
            .map(|_| 0.0)
            .scan(seeded(7), |r, _| Some(r.random()))
            .collect();
        assert_eq!(a, b);
    }

    #[test]
    fn a_stream_family_gives_the_streams_of_its_full_labels() {
        let draw = |mut rng: SimRng| rng.random::<u64>();
        for (seed, step, i) in [(0, 0, 0), (7, 3, 99), (u64::MAX, 1 << 40, 5)] {
            let family = Streams::new(seed, &[step]);
            assert_eq!(
                draw(family.stream(&[i, 2])),
                draw(stream(seed, &[step, i, 2]))
            );
            assert_eq!(draw(family.stream(&[])), draw(stream(seed, &[step])));
        }
        assert_eq!(
            draw(Streams::new(4, &[]).stream(&[1])),
            draw(stream(4, &[1]))
        );
    }

    #[test]
    fn streams_differ_by_label_and_order() {
        let draw = |labels: &[u64]| stream(1, labels).random::<u64>();
        assert_ne!(draw(&[0, 1]), draw(&[1, 0]));
        assert_ne!(draw(&[0, 1]), draw(&[0, 2]));
        assert_eq!(draw(&[3, 4]), draw(&[3, 4]));
    }
}
