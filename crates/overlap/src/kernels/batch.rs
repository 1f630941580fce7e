//! `ocsi_batch`: our step beyond the papers. OCSI (Algorithm 5) vectorised across
//! configurations instead of across the three axes: one SIMD lane per configuration, read from
//! the blocks of a [`Batch`](crate::Batch), verdicts packed into a bitset. With FMA and a branch-free body the
//! loop is limited by memory bandwidth, not arithmetic.
//!
//! The instruction set is chosen at run time ([`Isa::best`]): AVX-512F, else AVX2+FMA, else
//! portable code.

use crate::batch::{BatchView, LANES, verdict_words};
use crate::config::Cuboid;
use crate::real::Real;

/// Runs `block_verdicts` (lane bit set = overlap) over every block and packs the results, 16
/// bits per block, into `verdicts`. Bits past `batch.len()` (the padding lanes) are cleared.
#[inline(always)]
fn pack_verdicts<T: Real>(
    batch: BatchView<'_, T>,
    verdicts: &mut [u64],
    mut block_verdicts: impl FnMut(&[T]) -> u16,
) {
    const BLOCKS_PER_WORD: usize = 64 / LANES;
    assert!(
        verdicts.len() >= verdict_words(batch.len()),
        "verdict bitset too short"
    );
    for (word, blocks) in verdicts
        .iter_mut()
        .zip(batch.values().chunks(BLOCKS_PER_WORD * crate::batch::BLOCK))
    {
        let mut bits = 0u64;
        for (k, block) in blocks.chunks_exact(crate::batch::BLOCK).enumerate() {
            bits |= (block_verdicts(block) as u64) << (k * LANES);
        }
        *word = bits;
    }
    let tail = batch.len() % 64;
    if tail != 0 {
        verdicts[batch.len() / 64] &= (1u64 << tail) - 1;
    }
}

/// Lanes of one block by plain code: the fallback, and the reference the SIMD paths must match.
#[inline(always)]
fn block_verdicts_portable<T: Real>(block: &[T], cuboid: &Cuboid<T>, r2: T) -> u16 {
    let field = |f: usize| &block[f * LANES..(f + 1) * LANES];
    let (rx, ry, rz) = (field(0), field(1), field(2));
    let mut bits = 0u16;
    for lane in 0..LANES {
        let mut d = T::ZERO;
        for axis in 0..3 {
            let e = 3 + 3 * axis;
            let a = rx[lane] * field(e)[lane]
                + ry[lane] * field(e + 1)[lane]
                + rz[lane] * field(e + 2)[lane];
            let l = (a.abs() - cuboid.half[axis]).positive_part();
            d = d + l * l;
        }
        bits |= ((d <= r2) as u16) << lane;
    }
    bits
}

fn ocsi_batch_portable<T: Real>(
    batch: BatchView<'_, T>,
    cuboid: &Cuboid<T>,
    radius: T,
    verdicts: &mut [u64],
) {
    let r2 = radius * radius;
    pack_verdicts(batch, verdicts, |block| {
        block_verdicts_portable(block, cuboid, r2)
    });
}

/// An instruction set the batched kernel can run on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Isa {
    Avx512,
    Avx2Fma,
    Portable,
}

impl Isa {
    /// Every instruction set this CPU can run, best first.
    pub fn available() -> Vec<Isa> {
        let mut isas = Vec::new();
        #[cfg(target_arch = "x86_64")]
        {
            if is_x86_feature_detected!("avx512f") {
                isas.push(Isa::Avx512);
            }
            if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
                isas.push(Isa::Avx2Fma);
            }
        }
        isas.push(Isa::Portable);
        isas
    }

    /// The best instruction set of this CPU (detected once; the check is a cached load).
    pub fn best() -> Isa {
        static BEST: std::sync::OnceLock<Isa> = std::sync::OnceLock::new();
        *BEST.get_or_init(|| Isa::available()[0])
    }

    pub fn name(self) -> &'static str {
        match self {
            Isa::Avx512 => "avx512f",
            Isa::Avx2Fma => "avx2+fma",
            Isa::Portable => "portable",
        }
    }
}

/// Panics if `isa` is not available: running AVX code on a CPU without it is undefined behaviour.
/// The list is detected once: the protocol calls a kernel per timed block, and the check must
/// cost a load, not a detection and an allocation.
fn assert_available(isa: Isa) {
    static AVAILABLE: std::sync::OnceLock<Vec<Isa>> = std::sync::OnceLock::new();
    assert!(
        AVAILABLE.get_or_init(Isa::available).contains(&isa),
        "{} is not available on this CPU",
        isa.name()
    );
}

pub fn ocsi_batch_f32(
    isa: Isa,
    batch: BatchView<'_, f32>,
    cuboid: &Cuboid<f32>,
    radius: f32,
    verdicts: &mut [u64],
) {
    assert_available(isa);
    match isa {
        // SAFETY: availability of the instruction set was asserted above.
        #[cfg(target_arch = "x86_64")]
        Isa::Avx512 => unsafe { x86::ocsi_batch_f32_avx512(batch, cuboid, radius, verdicts) },
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2Fma => unsafe { x86::ocsi_batch_f32_avx2(batch, cuboid, radius, verdicts) },
        _ => ocsi_batch_portable(batch, cuboid, radius, verdicts),
    }
}

pub fn ocsi_batch_f64(
    isa: Isa,
    batch: BatchView<'_, f64>,
    cuboid: &Cuboid<f64>,
    radius: f64,
    verdicts: &mut [u64],
) {
    assert_available(isa);
    match isa {
        // SAFETY: availability of the instruction set was asserted above.
        #[cfg(target_arch = "x86_64")]
        Isa::Avx512 => unsafe { x86::ocsi_batch_f64_avx512(batch, cuboid, radius, verdicts) },
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2Fma => unsafe { x86::ocsi_batch_f64_avx2(batch, cuboid, radius, verdicts) },
        _ => ocsi_batch_portable(batch, cuboid, radius, verdicts),
    }
}

/// The same arithmetic as [`block_verdicts_portable`], `W` lanes per register:
/// a_i = fma(r_x, e_ix, fma(r_y, e_iy, r_z·e_iz)), l_i = max(|a_i| − c_i, 0), d = Σ l_i².
#[cfg(target_arch = "x86_64")]
pub(crate) mod x86 {
    use std::arch::x86_64::*;

    use super::{BatchView, Cuboid, LANES, pack_verdicts};

    /// Loads field `f` of a block at lane offset `at`.
    macro_rules! field {
        ($load:ident, $block:expr, $f:expr, $at:expr) => {
            // SAFETY: a block holds FIELDS × LANES values and `at` + register width ≤ LANES.
            unsafe { $load($block.as_ptr().add($f * LANES + $at)) }
        };
    }

    #[target_feature(enable = "avx512f")]
    pub unsafe fn ocsi_batch_f32_avx512(
        batch: BatchView<'_, f32>,
        cuboid: &Cuboid<f32>,
        radius: f32,
        verdicts: &mut [u64],
    ) {
        let c = cuboid.half.map(|c| _mm512_set1_ps(c));
        let r2 = _mm512_set1_ps(radius * radius);
        pack_verdicts(batch, verdicts, |block| {
            let f = |i| field!(_mm512_loadu_ps, block, i, 0);
            let (rx, ry, rz) = (f(0), f(1), f(2));
            let mut d = _mm512_setzero_ps();
            #[allow(clippy::needless_range_loop)] // axis picks a field offset as well as c[axis]
            for axis in 0..3 {
                let e = 3 + 3 * axis;
                let a = _mm512_fmadd_ps(
                    rx,
                    f(e),
                    _mm512_fmadd_ps(ry, f(e + 1), _mm512_mul_ps(rz, f(e + 2))),
                );
                let l = _mm512_max_ps(
                    _mm512_sub_ps(_mm512_abs_ps(a), c[axis]),
                    _mm512_setzero_ps(),
                );
                d = _mm512_fmadd_ps(l, l, d);
            }
            _mm512_cmp_ps_mask::<_CMP_LE_OQ>(d, r2)
        });
    }

    #[target_feature(enable = "avx512f")]
    pub unsafe fn ocsi_batch_f64_avx512(
        batch: BatchView<'_, f64>,
        cuboid: &Cuboid<f64>,
        radius: f64,
        verdicts: &mut [u64],
    ) {
        let c = cuboid.half.map(|c| _mm512_set1_pd(c));
        let r2 = _mm512_set1_pd(radius * radius);
        pack_verdicts(batch, verdicts, |block| {
            let half = |at: usize| {
                let f = |i| field!(_mm512_loadu_pd, block, i, at);
                let (rx, ry, rz) = (f(0), f(1), f(2));
                let mut d = _mm512_setzero_pd();
                #[allow(clippy::needless_range_loop)]
                // axis picks a field offset as well as c[axis]
                for axis in 0..3 {
                    let e = 3 + 3 * axis;
                    let a = _mm512_fmadd_pd(
                        rx,
                        f(e),
                        _mm512_fmadd_pd(ry, f(e + 1), _mm512_mul_pd(rz, f(e + 2))),
                    );
                    let l = _mm512_max_pd(
                        _mm512_sub_pd(_mm512_abs_pd(a), c[axis]),
                        _mm512_setzero_pd(),
                    );
                    d = _mm512_fmadd_pd(l, l, d);
                }
                _mm512_cmp_pd_mask::<_CMP_LE_OQ>(d, r2) as u16
            };
            half(0) | half(8) << 8
        });
    }

    #[target_feature(enable = "avx2,fma")]
    pub unsafe fn ocsi_batch_f32_avx2(
        batch: BatchView<'_, f32>,
        cuboid: &Cuboid<f32>,
        radius: f32,
        verdicts: &mut [u64],
    ) {
        let c = cuboid.half.map(|c| _mm256_set1_ps(c));
        let r2 = _mm256_set1_ps(radius * radius);
        let sign = _mm256_set1_ps(-0.0);
        pack_verdicts(batch, verdicts, |block| {
            let part = |at: usize| {
                let f = |i| field!(_mm256_loadu_ps, block, i, at);
                let (rx, ry, rz) = (f(0), f(1), f(2));
                let mut d = _mm256_setzero_ps();
                #[allow(clippy::needless_range_loop)]
                // axis picks a field offset as well as c[axis]
                for axis in 0..3 {
                    let e = 3 + 3 * axis;
                    let a = _mm256_fmadd_ps(
                        rx,
                        f(e),
                        _mm256_fmadd_ps(ry, f(e + 1), _mm256_mul_ps(rz, f(e + 2))),
                    );
                    let l = _mm256_max_ps(
                        _mm256_sub_ps(_mm256_andnot_ps(sign, a), c[axis]),
                        _mm256_setzero_ps(),
                    );
                    d = _mm256_fmadd_ps(l, l, d);
                }
                _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(d, r2)) as u16
            };
            part(0) | part(8) << 8
        });
    }

    #[target_feature(enable = "avx2,fma")]
    pub unsafe fn ocsi_batch_f64_avx2(
        batch: BatchView<'_, f64>,
        cuboid: &Cuboid<f64>,
        radius: f64,
        verdicts: &mut [u64],
    ) {
        let c = cuboid.half.map(|c| _mm256_set1_pd(c));
        let r2 = _mm256_set1_pd(radius * radius);
        let sign = _mm256_set1_pd(-0.0);
        pack_verdicts(batch, verdicts, |block| {
            let part = |at: usize| {
                let f = |i| field!(_mm256_loadu_pd, block, i, at);
                let (rx, ry, rz) = (f(0), f(1), f(2));
                let mut d = _mm256_setzero_pd();
                #[allow(clippy::needless_range_loop)]
                // axis picks a field offset as well as c[axis]
                for axis in 0..3 {
                    let e = 3 + 3 * axis;
                    let a = _mm256_fmadd_pd(
                        rx,
                        f(e),
                        _mm256_fmadd_pd(ry, f(e + 1), _mm256_mul_pd(rz, f(e + 2))),
                    );
                    let l = _mm256_max_pd(
                        _mm256_sub_pd(_mm256_andnot_pd(sign, a), c[axis]),
                        _mm256_setzero_pd(),
                    );
                    d = _mm256_fmadd_pd(l, l, d);
                }
                _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_LE_OQ>(d, r2)) as u16
            };
            part(0) | part(4) << 4 | part(8) << 8 | part(12) << 12
        });
    }
}
