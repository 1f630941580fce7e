//! xoshiro256++ seeded through SplitMix64 (Blackman & Vigna). Written out here, not taken from a
//! crate, so that a point's configurations are reproducible from its seed for as long as this
//! file does not change, whatever happens to a dependency's stream.

#[derive(Clone, Debug)]
pub struct Rng {
    s: [u64; 4],
}

/// One step of SplitMix64: also the mixer that derives independent seeds.
pub fn splitmix64(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A seed for stream `index` of `seed`: repeats and parallel chunks get independent streams.
pub fn derive_seed(seed: u64, index: u64) -> u64 {
    let mut state = seed ^ index.wrapping_mul(0xD1B5_4A32_D192_ED03);
    splitmix64(&mut state)
}

impl Rng {
    pub fn new(seed: u64) -> Self {
        let mut state = seed;
        Self {
            s: std::array::from_fn(|_| splitmix64(&mut state)),
        }
    }

    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        let s = &mut self.s;
        let result = s[0].wrapping_add(s[3]).rotate_left(23).wrapping_add(s[0]);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        result
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
        // Stored configurations and point ids were drawn from this stream: a change to any value
        // here means old seeds no longer reproduce old results.
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
