//! xoshiro256++ seeded through SplitMix64 (Blackman & Vigna), as `rand_xoshiro` implements them.
//! A point's configurations and its id mean something only while a seed gives the same stream:
//! `reference_stream_is_stable` pins the stream to the values of the hand-written generator this
//! replaced, so a dependency update that changed it fails CI.

use rand_xoshiro::rand_core::{Rng as _, SeedableRng};
use rand_xoshiro::{SplitMix64, Xoshiro256PlusPlus};

#[derive(Clone, Debug)]
pub struct Rng(Xoshiro256PlusPlus);

/// A seed for stream `index` of `seed`: repeats and parallel chunks get independent streams.
/// One SplitMix64 step mixes the index into the seed.
pub fn derive_seed(seed: u64, index: u64) -> u64 {
    SplitMix64::seed_from_u64(seed ^ index.wrapping_mul(0xD1B5_4A32_D192_ED03)).next_u64()
}

impl Rng {
    /// The state is the first four SplitMix64 outputs from `seed` (`seed_from_u64`), the seeding
    /// Blackman & Vigna recommend.
    pub fn new(seed: u64) -> Self {
        Self(Xoshiro256PlusPlus::seed_from_u64(seed))
    }

    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }

    /// Uniform in [0, 1), 53 random bits.
    #[inline]
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [−1, 1).
    #[inline]
    pub fn symmetric(&mut self) -> f64 {
        2.0 * self.uniform() - 1.0
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
        // Stored results were measured on configurations drawn from this stream, and a point id
        // names only the seed: a change to any value here means old ids no longer reproduce them.
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
        // (seed, digest of next_u64, of uniform's bits, of derive_seed(seed, 0..1000)), each over
        // the first 1,000 values.
        let pinned = [
            (
                0,
                0x4035_2D17_8B23_2A37,
                0x1ACA_8522_E687_AD1F,
                0x4CA0_5B01_B987_E4D6,
            ),
            (
                1,
                0xF1B5_11D8_EE9A_2366,
                0x7182_FD72_5302_5EE4,
                0xB8AA_D5E1_0AB6_06C3,
            ),
            (
                u64::MAX,
                0x4FDE_618B_F3B3_6F07,
                0x273B_5DA1_AB19_CB7D,
                0x1728_C8FF_A237_21BA,
            ),
            (
                0x243F_6A88_85A3_08D3,
                0x3BBF_3DDA_90E8_8E91,
                0x84B0_530B_2D23_FAD4,
                0x3D20_9D3C_B5E5_FC7E,
            ),
        ];
        for (seed, words, uniforms, derived) in pinned {
            let mut r = Rng::new(seed);
            assert_eq!(
                digest((0..1000).map(|_| r.next_u64())),
                words,
                "seed {seed}"
            );
            let mut r = Rng::new(seed);
            assert_eq!(
                digest((0..1000).map(|_| r.uniform().to_bits())),
                uniforms,
                "seed {seed}"
            );
            assert_eq!(
                digest((0..1000).map(|i| derive_seed(seed, i))),
                derived,
                "seed {seed}"
            );
        }
        assert_eq!(derive_seed(1, 2), 0x09A2_3C3A_0FFE_DFE9);
        let mut r = Rng::new(1);
        assert_eq!(r.uniform(), 0.811_612_158_881_884_8);
        assert_eq!(r.symmetric(), 2.0 * 0.747_104_716_158_218_7 - 1.0);
    }
}
