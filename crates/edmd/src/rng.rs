//! xoshiro256++ seeded through SplitMix64 (Blackman & Vigna), as `rand_xoshiro` implements them,
//! plus Box–Muller normals.
//!
//! A run is reproducible from its seed only while the seed gives the same stream:
//! `reference_stream_is_stable` pins the stream to the values of the hand-written generator this
//! replaced, so a dependency update that changed it fails CI.

use rand_xoshiro::Xoshiro256PlusPlus;
use rand_xoshiro::rand_core::{Rng as _, SeedableRng};

#[derive(Clone, Debug)]
pub struct Rng {
    xoshiro: Xoshiro256PlusPlus,
    /// Second Box–Muller deviate, kept so no draw is wasted.
    spare: Option<f64>,
}

impl Rng {
    /// The state is the first four SplitMix64 outputs from `seed` (`seed_from_u64`), the seeding
    /// Blackman & Vigna recommend.
    pub fn new(seed: u64) -> Self {
        Rng {
            xoshiro: Xoshiro256PlusPlus::seed_from_u64(seed),
            spare: None,
        }
    }

    pub fn next_u64(&mut self) -> u64 {
        self.xoshiro.next_u64()
    }

    /// Uniform in [0, 1) with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }

    /// Standard normal deviate by the Box–Muller transform.
    pub fn normal(&mut self) -> f64 {
        if let Some(z) = self.spare.take() {
            return z;
        }
        // 1 - u lies in (0, 1], so the logarithm is finite.
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        let rad = (-2.0 * u1.ln()).sqrt();
        let (s, c) = (std::f64::consts::TAU * u2).sin_cos();
        self.spare = Some(rad * s);
        rad * c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// FNV-1a over 64-bit words: a thousand draws pinned by one number.
    fn digest(words: impl Iterator<Item = u64>) -> u64 {
        words.fold(0xCBF2_9CE4_8422_2325, |h, w| {
            (h ^ w).wrapping_mul(0x0000_0100_0000_01B3)
        })
    }

    #[test]
    fn reference_stream_is_stable() {
        // A run's initial state is drawn from this stream: a change to any value here means old
        // seeds no longer reproduce old trajectories.
        let mut r = Rng::new(0);
        let first: [u64; 4] = std::array::from_fn(|_| r.next_u64());
        assert_eq!(
            first,
            [
                0x5317_5D61_490B_23DF,
                0x61DA_6F3D_C380_D507,
                0x5C0F_DF91_EC9A_7BFC,
                0x02EE_BF8C_3BBE_5E1A
            ]
        );
        // (seed, digest of next_u64, of normal's bits, of uniform and normal interleaved), each
        // over the first 1,000 values. The normals go through std's ln and sin_cos, i.e. the
        // platform's libm: these are glibc's (x86-64 Linux, as CI).
        let pinned = [
            (
                0,
                0x4035_2D17_8B23_2A37,
                0xC140_76C8_6A52_E392,
                0xD1DA_ECD5_E58D_56D4,
            ),
            (
                1,
                0xF1B5_11D8_EE9A_2366,
                0xA891_38A1_B43D_14D4,
                0xD4A2_E575_57E4_7288,
            ),
            (
                u64::MAX,
                0x4FDE_618B_F3B3_6F07,
                0x7971_E295_85D7_6858,
                0xF32E_B6EB_A4F8_D147,
            ),
            (
                0x243F_6A88_85A3_08D3,
                0x3BBF_3DDA_90E8_8E91,
                0xD69E_24D3_F62F_2B73,
                0x4AB7_CDBB_3690_97E6,
            ),
        ];
        for (seed, words, normals, mixed) in pinned {
            let mut r = Rng::new(seed);
            assert_eq!(
                digest((0..1000).map(|_| r.next_u64())),
                words,
                "seed {seed}"
            );
            let mut r = Rng::new(seed);
            assert_eq!(
                digest((0..1000).map(|_| r.normal().to_bits())),
                normals,
                "seed {seed}"
            );
            let mut r = Rng::new(seed);
            let draws = (0..1000).map(|i| {
                if i % 3 == 0 {
                    r.uniform().to_bits()
                } else {
                    r.normal().to_bits()
                }
            });
            assert_eq!(digest(draws), mixed, "seed {seed}");
        }
        let mut r = Rng::new(1);
        assert_eq!(r.normal(), -0.033_237_095_940_591_98);
        assert_eq!(r.normal(), -1.826_855_278_471_096_5);
        assert_eq!(r.range(-3.5, 0.25), -3.124_434_111_748_311);
    }

    #[test]
    fn normal_moments() {
        let mut r = Rng::new(42);
        let n = 200_000;
        let (mut m1, mut m2) = (0.0, 0.0);
        for _ in 0..n {
            let z = r.normal();
            m1 += z;
            m2 += z * z;
        }
        m1 /= n as f64;
        m2 /= n as f64;
        assert!(m1.abs() < 0.01, "mean {m1}");
        assert!((m2 - 1.0).abs() < 0.01, "variance {m2}");
    }
}
