//! Shared test helpers: a small deterministic random generator (SplitMix64, Steele, Lea &
//! Flood 2014) so that the tests need no external crate and keep fixed seeds.
#![allow(dead_code)]

pub mod elastic;

/// SplitMix64.
pub struct Rng(pub u64);

impl Rng {
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
}

/// A jittered cubic lattice of n^3 points with spacing dx from `origin` (cell centres), each
/// moved by up to `jitter` dx per axis.
pub fn jittered_lattice(
    rng: &mut Rng,
    n: usize,
    dx: f64,
    origin: [f64; 3],
    jitter: f64,
) -> Vec<[f64; 3]> {
    let mut out = Vec::with_capacity(n * n * n);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let c = [i, j, k].map(|q| q as f64 + 0.5);
                out.push([0, 1, 2].map(|a| origin[a] + dx * (c[a] + rng.range(-jitter, jitter))));
            }
        }
    }
    out
}
