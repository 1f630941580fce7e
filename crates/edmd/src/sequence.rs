//! A compact fingerprint of a run's collision sequence, to tell how long two runs from the same
//! initial state stay on the same trajectory (the accuracy report compares each setting of a knob
//! with the tightest one).
//!
//! The pairs (i, j) of the first [`BLOCKS`] × [`BLOCK`] collisions feed a chained hash (each
//! collision mixes its ordered pair into the state), and the state is kept after every
//! [`BLOCK`] collisions, truncated to 32 bits. Because the hash is chained, two runs' blocks are
//! equal up to the first collision where they part and (but for a 2⁻³² coincidence per block)
//! differ from there on: the first differing block bounds where the sequences diverged (the
//! accuracy report finds it, `crates/report/src/accuracy.rs`).
//!
//! The cost is one multiply and a few integer operations per collision, and nothing at all after
//! the first 65,536 collisions.

/// Collisions per fingerprint block.
pub const BLOCK: u32 = 64;
/// Blocks kept: the fingerprint covers the first `BLOCK × BLOCKS` = 65,536 collisions.
pub const BLOCKS: usize = 1024;

/// The fingerprint being built, one collision at a time.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Fingerprint {
    state: u64,
    in_block: u32,
    blocks: Vec<u32>,
}

impl Fingerprint {
    /// One collision between `i` and `j` (either order: the pair is what counts).
    #[inline]
    pub fn record(&mut self, i: u32, j: u32) {
        if self.blocks.len() == BLOCKS {
            return;
        }
        let pair = (u64::from(i.min(j)) << 32) | u64::from(i.max(j));
        // A multiply-xorshift mix (as in splitmix64's finaliser) of the state and the pair.
        let mixed = (self.state ^ pair).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        self.state = mixed ^ (mixed >> 29);
        self.in_block += 1;
        if self.in_block == BLOCK {
            self.in_block = 0;
            self.blocks.push((self.state ^ (self.state >> 32)) as u32);
        }
    }

    /// The complete blocks so far (a partial last block is left out).
    pub fn blocks(&self) -> &[u32] {
        &self.blocks
    }

    /// The blocks as lowercase hex, 8 digits each, for a JSON record.
    pub fn to_hex(&self) -> String {
        self.blocks.iter().map(|b| format!("{b:08x}")).collect()
    }
}

/// The blocks of a fingerprint written by [`Fingerprint::to_hex`]; `None` if `hex` is not one.
pub fn blocks_from_hex(hex: &str) -> Option<Vec<u32>> {
    if !hex.len().is_multiple_of(8) || !hex.is_ascii() {
        return None;
    }
    (0..hex.len())
        .step_by(8)
        .map(|k| u32::from_str_radix(&hex[k..k + 8], 16).ok())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fingerprint(pairs: impl IntoIterator<Item = (u32, u32)>) -> Fingerprint {
        let mut f = Fingerprint::default();
        for (i, j) in pairs {
            f.record(i, j);
        }
        f
    }

    fn pairs(n: usize) -> Vec<(u32, u32)> {
        (0..n as u32)
            .map(|k| (k % 97, (k * 31 + 5) % 256))
            .collect()
    }

    #[test]
    fn equal_sequences_give_equal_blocks_and_the_pair_order_does_not_count() {
        let a = fingerprint(pairs(1000));
        let b = fingerprint(pairs(1000).into_iter().map(|(i, j)| (j, i)));
        assert_eq!(a.blocks().len(), 1000 / BLOCK as usize);
        assert_eq!(a.blocks(), b.blocks());
    }

    #[test]
    fn a_changed_collision_shows_in_its_block_and_every_later_one() {
        let mut changed = pairs(4096);
        changed[1000] = (3, 4);
        let (a, b) = (fingerprint(pairs(4096)), fingerprint(changed));
        assert_eq!(a.blocks()[..15], b.blocks()[..15]);
        assert!(
            a.blocks()[15..]
                .iter()
                .zip(&b.blocks()[15..])
                .all(|(x, y)| x != y)
        );
        // Two collisions swapped are a different sequence too.
        let mut swapped = pairs(4096);
        swapped.swap(130, 131);
        let swapped = fingerprint(swapped);
        assert_eq!(a.blocks()[..2], swapped.blocks()[..2]);
        assert_ne!(a.blocks()[2], swapped.blocks()[2]);
    }

    #[test]
    fn it_stops_after_its_last_block_and_round_trips_through_hex() {
        let f = fingerprint(pairs(BLOCK as usize * BLOCKS + 500));
        assert_eq!(f.blocks().len(), BLOCKS);
        let hex = f.to_hex();
        assert_eq!(hex.len(), 8 * BLOCKS);
        assert_eq!(blocks_from_hex(&hex).as_deref(), Some(f.blocks()));
        assert_eq!(blocks_from_hex("abc"), None);
        assert_eq!(blocks_from_hex("0000000g"), None);
    }
}
