//! Per-pair kernels from outside the workspace: C plugins of `include/sweep_overlap.h` (ABI 1),
//! checked against Eq. 2 and timed exactly as the built-in per-pair kernels are. Loading the
//! shared library is the caller's business (this crate knows no files): it hands over the
//! entry points as [`Foreign`] kernels.
//!
//! The ABI takes a configuration as three arrays (r_SC, ê_T/ê_L/ê_W, half extents), as the
//! papers' harness passes pointers into its arrays. [`crate::Batch`] keeps blocks of 16 with each
//! field contiguous, where no configuration is an array: a point with plugins therefore also keeps
//! a [`Packed`] copy of each set (12 values per configuration, r_SC then the three axes), filled
//! from the batch outside the timed loops, and a plugin is called with pointers into it. The
//! plugin's timed call is thus: two pointer computations, one indirect call through the C ABI,
//! its own loads of the 12 values and 3 half extents, its arithmetic, the return. No copy is
//! made inside the timed loop (a gather into stack arrays there would add stores and
//! store-forwarding stalls that the built-in kernels, which read the batch in place, do not pay),
//! and a plugin streams the same 12 values per configuration from memory that the built-ins do.

use std::cmp::Ordering;
use std::ffi::c_int;
use std::hint::black_box;

use serde::{Deserialize, Serialize};

use crate::batch::Batch;
use crate::config::{Configuration, Cuboid};
use crate::error::OverlapError;
use crate::exact::{beyond_rounding, margin_sign};
use crate::protocol::PointSpec;
use crate::real::Real;
use crate::verdicts::CheckingSet;

/// A plugin a point times beside its built-in algorithms, as its spec names it: the file, and
/// the BLAKE3 hash (lowercase hex) of its bytes when the plan was read. The hash is part of the
/// point's id, so a rebuilt plugin is a new point; a worker runs the file only if it still has
/// that hash.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct PluginFile {
    pub path: String,
    pub blake3: String,
}

/// `sweep_overlap_f32` / `sweep_overlap_f64`: r_SC (3 values), the axes ê_T, ê_L, ê_W (3 × 3),
/// the half extents c_T, c_L, c_W and R → 1 when sphere and cuboid overlap (or touch), else 0.
pub type ForeignFn<T> = unsafe extern "C" fn(*const T, *const [T; 3], *const T, T) -> c_int;

/// One plugin's kernel in one precision, with the name it reports (its algorithm column).
#[derive(Clone, Debug)]
pub struct Foreign<T> {
    name: String,
    kernel: ForeignFn<T>,
}

impl<T: Real> Foreign<T> {
    /// # Safety
    /// `kernel` must be a function of the ABI's signature that reads only the arrays it is
    /// given, and stay callable (its library loaded) as long as this value lives.
    pub unsafe fn new(name: String, kernel: ForeignFn<T>) -> Self {
        Self { name, kernel }
    }

    pub fn name(&self) -> &str {
        &self.name
    }

    /// The plugin's verdict for one configuration; nonzero is an overlap.
    pub fn overlaps(&self, cfg: &Configuration<T>, cuboid: &Cuboid<T>, radius: T) -> bool {
        // SAFETY: `new`'s contract; the three pointers are to arrays of 3, 3 × 3 and 3 values
        // that outlive the call.
        unsafe {
            (self.kernel)(
                cfg.r_sc.as_ptr(),
                cfg.axes.as_ptr(),
                cuboid.half.as_ptr(),
                radius,
            ) != 0
        }
    }
}

/// Values of one configuration in a [`Packed`] set: r_SC, then ê_T, ê_L, ê_W.
pub const PACKED: usize = 12;

/// A configuration set as consecutive arrays of [`PACKED`] values, the layout the ABI points
/// into; see the module's doc for why it exists and what it costs.
#[derive(Clone, Debug, Default)]
pub struct Packed<T> {
    values: Vec<T>,
}

impl<T: Real> Packed<T> {
    /// Rewrites this copy from `batch` (untimed).
    pub fn fill(&mut self, batch: &Batch<T>) {
        self.values.clear();
        self.values.reserve(batch.len() * PACKED);
        for i in 0..batch.len() {
            let c = batch.get(i);
            self.values.extend_from_slice(&c.r_sc);
            self.values.extend(c.axes.iter().flatten());
        }
    }

    /// Configurations `range` of the set.
    pub fn range(&self, range: std::ops::Range<usize>) -> &[T] {
        &self.values[range.start * PACKED..range.end * PACKED]
    }

    pub fn values(&self) -> &[T] {
        &self.values
    }
}

/// The timed loop of a plugin, as [`crate::protocol::count_overlaps`] is a built-in's: the
/// plugin called through a function pointer once per configuration of `configs` (a run of a
/// [`Packed`] set), returning how many overlap.
#[inline(never)]
pub fn count_foreign<T: Real>(
    kernel: &Foreign<T>,
    configs: &[T],
    cuboid: &Cuboid<T>,
    radius: T,
) -> u64 {
    let call = black_box(kernel.kernel);
    let half = cuboid.half.as_ptr();
    configs
        .chunks_exact(PACKED)
        .map(|c| {
            // SAFETY: `Foreign::new`'s contract; `c` holds r_SC (3 values) then the axes (9),
            // and `half` 3 values, all alive during the call.
            let verdict =
                unsafe { call(c.as_ptr(), c[3..].as_ptr().cast::<[T; 3]>(), half, radius) };
            u64::from(verdict != 0)
        })
        .sum()
}

/// Checks `kernel` on the point's checking set ([`CheckingSet`]: `configurations`
/// configurations from `seed`, bulk and near-contact shell) before it is timed: the first
/// verdict that differs from Eq. 2 decided exactly, where rounding cannot explain it (outside
/// [`crate::exact::rounding_band`]), is an error naming the plugin and the configuration.
/// Configurations the exact evaluation refuses are skipped, as in [`crate::verdicts`].
pub fn check_foreign<T: Real>(
    spec: &PointSpec,
    kernel: &Foreign<T>,
    configurations: u64,
    seed: u64,
) -> Result<(), OverlapError> {
    let cuboid = Cuboid::<T>::from_reduced(spec.l_star, spec.w_star);
    let radius = T::from_f64(spec.r_star);
    let set = CheckingSet::<T>::draw(spec, configurations, seed);
    for cfg in set.bulk.iter().chain(&set.shell) {
        let Ok(sign) = margin_sign(cfg, &cuboid, radius) else {
            continue;
        };
        let exact = sign != Ordering::Greater;
        let got = kernel.overlaps(cfg, &cuboid, radius);
        if got != exact && beyond_rounding(cfg, &cuboid, radius) {
            let verdict = |overlap: bool| if overlap { "overlap" } else { "no overlap" };
            return Err(OverlapError::WrongVerdict {
                algorithm: kernel.name.clone(),
                reason: format!(
                    "says {} where Eq. 2 says {} ({}): r_sc = {:?}, axes = {:?}, half = {:?}, radius = {:?}",
                    verdict(got),
                    verdict(exact),
                    T::NAME,
                    cfg.r_sc,
                    cfg.axes,
                    cuboid.half,
                    radius
                ),
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::algorithm::{Algorithm, Precision};
    use crate::sampler::generate;

    unsafe extern "C" fn always(_: *const f64, _: *const [f64; 3], _: *const f64, _: f64) -> c_int {
        1
    }

    /// OCSI through the ABI, as a C plugin would write it.
    unsafe extern "C" fn ocsi_abi(
        r: *const f64,
        axes: *const [f64; 3],
        half: *const f64,
        radius: f64,
    ) -> c_int {
        // SAFETY: the ABI's arrays.
        let (r, axes, half) = unsafe {
            (
                std::slice::from_raw_parts(r, 3),
                std::slice::from_raw_parts(axes, 3),
                std::slice::from_raw_parts(half, 3),
            )
        };
        let d2: f64 = (0..3)
            .map(|i| {
                let a = r[0] * axes[i][0] + r[1] * axes[i][1] + r[2] * axes[i][2];
                let s = (a.abs() - half[i]).max(0.0);
                s * s
            })
            .sum();
        c_int::from(d2 <= radius * radius)
    }

    fn point() -> PointSpec {
        PointSpec {
            l_star: 3.0,
            w_star: 2.0,
            r_star: 0.7,
            acceptance: 0.4,
            configurations: 2000,
            repeats: 1,
            precision: Precision::F64,
            algorithms: vec![Algorithm::Ocsi],
            seed: 1,
            ci_target: None,
            time_cap_s: None,
            verdict_check: None,
            visit: None,
            plugins: Vec::new(),
        }
    }

    #[test]
    fn a_right_plugin_passes_and_a_wrong_one_is_named_with_its_configuration() {
        // SAFETY: both functions have the ABI's signature and live for the program.
        let (right, wrong) = unsafe {
            (
                Foreign::new("ocsi_c".into(), ocsi_abi as ForeignFn<f64>),
                Foreign::new("always".into(), always as ForeignFn<f64>),
            )
        };
        check_foreign(&point(), &right, 4000, 7).expect("OCSI through the ABI is exact");
        let error = check_foreign(&point(), &wrong, 4000, 7)
            .expect_err("always 1 is wrong")
            .to_string();
        assert!(error.contains("always"), "{error}");
        assert!(
            error.contains("says overlap where Eq. 2 says no overlap"),
            "{error}"
        );
        assert!(
            error.contains("r_sc = [") && error.contains("radius = 0.7"),
            "{error}"
        );
    }

    #[test]
    fn the_packed_copy_and_the_timed_loop_see_the_batch() {
        let spec = point();
        let batch = generate::<f64>(&spec.spherocuboid(), 1000, 3);
        let mut packed = Packed::default();
        packed.fill(&batch);
        assert_eq!(packed.values().len(), 1000 * PACKED);
        assert_eq!(&packed.range(5..6)[..3], &batch.get(5).r_sc);
        // SAFETY: as above.
        let kernel = unsafe { Foreign::new("ocsi_c".into(), ocsi_abi as ForeignFn<f64>) };
        let cuboid = Cuboid::from_reduced(spec.l_star, spec.w_star);
        let expected = (0..1000)
            .filter(|&i| crate::overlaps(Algorithm::Ocsi, &batch.get(i), &cuboid, 0.7))
            .count() as u64;
        assert!(expected > 0 && expected < 1000);
        assert_eq!(
            count_foreign(&kernel, packed.range(0..1000), &cuboid, 0.7),
            expected
        );
    }
}
