//! Configurations stored for streaming: blocks of [`LANES`] configurations, each block holding
//! its 12 fields as 12 contiguous runs of [`LANES`] values (array-of-structures-of-arrays).
//!
//! One allocation, read front to back by every algorithm, so the hardware sees a single stream;
//! a block is one SIMD load per field for the batched kernel (16 × f32 = one AVX-512 register),
//! and generation fills blocks independently in parallel.

use crate::config::{Configuration, ConfigurationView};
use crate::real::Real;

/// Configurations per block.
pub const LANES: usize = 16;
/// r_SC (3) and ê_T, ê_L, ê_W (3 × 3).
pub const FIELDS: usize = 12;
/// Values per block.
pub const BLOCK: usize = LANES * FIELDS;

#[derive(Clone, Debug)]
pub struct Batch<T> {
    len: usize,
    data: Vec<T>,
}

impl<T: Real> Batch<T> {
    /// `len` configurations, all zero (sphere at the cuboid centre, degenerate axes) until written.
    pub fn zeroed(len: usize) -> Self {
        Self {
            len,
            data: vec![T::ZERO; len.div_ceil(LANES) * BLOCK],
        }
    }

    pub fn from_configurations(configs: &[Configuration<T>]) -> Self {
        let mut batch = Self::zeroed(configs.len());
        for (i, c) in configs.iter().enumerate() {
            batch.set(i, c);
        }
        batch
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Bytes held by the arrays (padding of the last block included).
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.data.as_slice())
    }

    pub fn values(&self) -> &[T] {
        &self.data
    }

    pub fn values_mut(&mut self) -> &mut [T] {
        &mut self.data
    }

    /// All configurations, borrowed: what the kernels read.
    pub fn view(&self) -> BatchView<'_, T> {
        BatchView {
            len: self.len,
            data: &self.data,
        }
    }

    /// Configuration `i` in place.
    #[inline(always)]
    pub fn lane(&self, i: usize) -> Lane<'_, T> {
        self.view().lane(i)
    }

    /// Configuration `i` copied out.
    pub fn get(&self, i: usize) -> Configuration<T> {
        let view = self.lane(i);
        Configuration {
            r_sc: std::array::from_fn(|j| view.r_sc(j)),
            axes: std::array::from_fn(|a| std::array::from_fn(|j| view.axis(a, j))),
        }
    }

    pub fn set(&mut self, i: usize, c: &Configuration<T>) {
        assert!(i < self.len, "configuration {i} out of {}", self.len);
        let block = &mut self.data[(i / LANES) * BLOCK..][..BLOCK];
        write_lane(block, i % LANES, c);
    }
}

/// A run of consecutive configurations of a [`Batch`], borrowed: the whole set, or one of the
/// short timed blocks of the protocol, read in place (no copy).
#[derive(Clone, Copy, Debug)]
pub struct BatchView<'a, T> {
    len: usize,
    data: &'a [T],
}

impl<'a, T: Real> BatchView<'a, T> {
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The values of every block of the run, padding lanes of the last block included.
    pub fn values(&self) -> &'a [T] {
        self.data
    }

    /// Configurations `configs` of this run. The start must be a multiple of 64, so that the
    /// run's verdicts begin on a word of a verdict bitset (and its first block on a block).
    pub fn range(&self, configs: std::ops::Range<usize>) -> BatchView<'a, T> {
        assert!(
            configs.start.is_multiple_of(64),
            "a run starts on a multiple of 64 configurations, not {}",
            configs.start
        );
        assert!(
            configs.start <= configs.end && configs.end <= self.len,
            "{configs:?} out of {}",
            self.len
        );
        let first = configs.start / LANES * BLOCK;
        let last = (configs.end.div_ceil(LANES) * BLOCK).max(first);
        BatchView {
            len: configs.len(),
            data: &self.data[first..last],
        }
    }

    /// Configuration `i` in place.
    #[inline(always)]
    pub fn lane(&self, i: usize) -> Lane<'a, T> {
        let block: &'a [T; BLOCK] = self.data[(i / LANES) * BLOCK..][..BLOCK]
            .try_into()
            .expect("a block is BLOCK values");
        Lane {
            block,
            lane: i % LANES,
        }
    }
}

/// One configuration inside its block: reads go straight to the arrays.
#[derive(Clone, Copy)]
pub struct Lane<'a, T> {
    block: &'a [T; BLOCK],
    lane: usize,
}

impl<T: Real> ConfigurationView<T> for Lane<'_, T> {
    #[inline(always)]
    fn r_sc(&self, j: usize) -> T {
        self.block[j * LANES + self.lane]
    }
    #[inline(always)]
    fn axis(&self, i: usize, j: usize) -> T {
        self.block[(3 + 3 * i + j) * LANES + self.lane]
    }
}

/// Writes configuration `c` into lane `lane` of one block.
#[inline]
pub fn write_lane<T: Real>(block: &mut [T], lane: usize, c: &Configuration<T>) {
    let fields = [
        c.r_sc[0],
        c.r_sc[1],
        c.r_sc[2], //
        c.axes[0][0],
        c.axes[0][1],
        c.axes[0][2], //
        c.axes[1][0],
        c.axes[1][1],
        c.axes[1][2], //
        c.axes[2][0],
        c.axes[2][1],
        c.axes[2][2],
    ];
    for (field, v) in fields.into_iter().enumerate() {
        block[field * LANES + lane] = v;
    }
}

/// Number of `u64` words of a verdict bitset for `len` configurations.
pub fn verdict_words(len: usize) -> usize {
    len.div_ceil(64)
}

/// Verdict `i` of a bitset written by a batched kernel.
pub fn verdict(bits: &[u64], i: usize) -> bool {
    bits[i / 64] >> (i % 64) & 1 == 1
}
