//! Is the machine disturbed? What each measurement of a point is checked against, and the rule
//! that flags a point measured while the machine was not itself.
//!
//! - **The core share**: the thread's CPU time over the wall time of its timed passes (the CPU
//!   clock is read before a pass's first block and after its last, never inside). Another
//!   process on the measuring core takes whole time slices: the blocks they fall in grow, the
//!   mean of the blocks grows with them (a busy loop on the core doubles Table 1), and the share
//!   falls to what the thread kept (0.5 beside one busy loop). Nothing else sees this: the
//!   references below are medians and percentiles, which skip the hit blocks.
//! - **The compute reference**: a fixed chain of dependent integer operations (no memory
//!   traffic, no branches to predict), timed in short blocks, median ns per step, before and
//!   after the point. It moves when the core itself gets slower: a lower clock, a busy SMT
//!   sibling, a hypervisor's steal.
//! - **The memory reference**: the plain read of the configuration arrays, the 5th percentile
//!   of its blocks, timed in every set after two untimed reads of the fresh set (the first reads
//!   pay for writing back what the generation left dirty; a set in the last-level cache reads
//!   steadily from the third read on). The first set's read is compared with the last set's:
//!   both are taken at the same moment of their set, so a quiet machine reads them alike. It
//!   moves when another process takes memory bandwidth or the shared cache.
//!
//! A point is flagged when its core share fell below [`CORE_SHARE_MIN`], when a reference moved
//! by more than its tolerance during the point, or when it is slower than the fastest this
//! thread measured over its recent points ([`Calibration`]; reads only against reads of sets of
//! the same size class): a slow phase that covers a whole point is invisible to a before/after
//! comparison. A flagged point is re-measured (`crate::protocol`).
//!
//! # The tolerances, from measured distributions
//! Measured on the 2-core development VM (`scripts/noise-calibration.sh`: 72 points per
//! condition, 10⁵, 10⁶ and 10⁷ configurations in f32 and f64, one thread's calibration carried
//! along, pinned to core 1); min / median / max of each signal, by set size:
//!
//! | signal | quiet | busy loop on the same core | 1 GiB stream on the other core |
//! |---|---|---|---|
//! | core share, 10⁵ | 0.982 / 1.001 / 1.001 | 0.651 / 0.922 / 1.002 | 0.996 / 1.001 / 1.003 |
//! | core share, 10⁶ | 0.998 / 0.999 / 0.999 | 0.506 / 0.524 / 0.553 | 0.951 / 0.999 / 0.999 |
//! | core share, 10⁷ | 0.999 / 1.000 / 1.000 | 0.500 / 0.503 / 0.505 | 0.994 / 0.998 / 1.000 |
//! | read end/start, 10⁵ | 1.000 / 1.008 / 1.440 | 1.000 / 1.020 / 1.830 | 1.000 / 1.031 / 1.538 |
//! | read end/start, 10⁶ | 1.001 / 1.028 / 1.128 | 1.000 / 1.033 / 1.151 | 1.008 / 1.067 / 1.528 |
//! | read end/start, 10⁷ | 1.000 / 1.013 / 1.098 | 1.001 / 1.013 / 1.075 | 1.004 / 1.041 / 1.577 |
//! | read/baseline, 10⁵ | 0.990 / 1.001 / 1.035 | 0.948 / 1.022 / 1.415 | 0.999 / 1.018 / 1.806 |
//! | read/baseline, 10⁶ | 0.956 / 1.043 / 1.154 | 0.907 / 1.017 / 1.094 | 0.701 / 1.245 / 1.612 |
//! | read/baseline, 10⁷ | 0.946 / 1.010 / 1.062 | 0.964 / 1.072 / 1.114 | 0.741 / 1.378 / 1.591 |
//! | compute/baseline, all | 1.000 / 1.025 / 1.062 | 1.001 / 1.020 / 1.055 | 1.001 / 1.013 / 1.043 |
//!
//! So: the core share is 1.00 on a quiet core (never below 0.98) and 0.50 beside a busy loop
//! over any pass long enough to span a time slice (short points of 10⁵ fall between slices and
//! keep most of their core: their blocks were not hit); [`CORE_SHARE_MIN`] = 0.95 lets a mean
//! through at most 5 % high. The compute reference never moved beyond 1.06 quietly:
//! [`COMPUTE_TOLERANCE`] = 1.10. Reads are the noisiest signal on a shared VM: sets in the
//! last-level cache (which other tenants share) vary up to 1.44× within a quiet point, sets in
//! memory up to 1.13×; [`STREAM_TOLERANCE`] = 1.5 and, against earlier reads of the size class,
//! [`STREAM_BASELINE_TOLERANCE`] = 1.3 (quiet at most 1.15×). A stream on the other core moved
//! reads from memory by 1.35–1.65× in some runs and not at all in others (the host's own
//! traffic decides); its worst readings exceed the tolerances, and a whole campaign under it is
//! named by the machine history (`results::machine_history`, which compares campaigns' medians
//! at 1.05 and 1.25). A frequency drop could not be caused on this VM. What these thresholds gave on
//! the quick plan and with each disturbance is in MEASUREMENTS.md.

use std::collections::{BTreeMap, VecDeque};
use std::hint::black_box;
use std::time::Instant;

/// Steps of the compute loop per timed block (about 10 µs on a 3 GHz core): short enough that
/// few blocks are hit by a scheduler tick or a time slice given away.
const COMPUTE_STEPS_PER_BLOCK: u64 = 8192;
/// Blocks of the compute reference: about 1.5 ms in all.
const COMPUTE_BLOCKS: usize = 128;
/// The slowest compute reference of a point may be this many times the fastest recent one.
pub const COMPUTE_TOLERANCE: f64 = 1.10;
/// The plain read may be this many times slower at one end of a point than at the other.
pub const STREAM_TOLERANCE: f64 = 1.5;
/// The faster of a point's two plain reads may be this many times slower than the fastest recent
/// read of sets of its size class.
pub const STREAM_BASELINE_TOLERANCE: f64 = 1.3;
/// The share of its core a thread must have had during its timed passes.
pub const CORE_SHARE_MIN: f64 = 0.95;
/// Compute references a thread remembers: a machine that got slower for good (a neighbour
/// that never leaves) becomes the new normal after this many, instead of flagging every point.
const CALIBRATION_WINDOW: usize = 16;

/// A fixed amount of work on the core alone: xorshift-multiply steps, each depending on the
/// last, so neither the compiler nor the CPU can overlap them.
#[inline(never)]
fn compute_steps(steps: u64, seed: u64) -> u64 {
    let mut x = seed | 1;
    for _ in 0..steps {
        x ^= x >> 29;
        x = x.wrapping_mul(0xbf58_476d_1ce4_e5b9);
    }
    x
}

/// The compute reference now: median ns per step over short blocks, after as many unmeasured
/// ones (a core that was idle may take a moment to reach its clock).
pub fn compute_reference_ns() -> f64 {
    for block in 0..COMPUTE_BLOCKS {
        black_box(compute_steps(
            black_box(COMPUTE_STEPS_PER_BLOCK),
            block as u64,
        ));
    }
    let mut per_step = Vec::with_capacity(COMPUTE_BLOCKS);
    for block in 0..COMPUTE_BLOCKS {
        let started = Instant::now();
        black_box(compute_steps(
            black_box(COMPUTE_STEPS_PER_BLOCK),
            block as u64,
        ));
        per_step.push(started.elapsed().as_secs_f64() * 1e9 / COMPUTE_STEPS_PER_BLOCK as f64);
    }
    crate::estimate::median(&per_step)
}

/// What a thread has measured of its core over its recent points. Keep one per pinned thread
/// and pass it to every point that thread measures.
#[derive(Clone, Debug, Default)]
pub struct Calibration {
    recent: VecDeque<f64>,
    /// The plain reads of recent sets, by size class ([`size_class`]): a read is only compared
    /// with reads of sets that sit in the same level of the memory hierarchy.
    streams: BTreeMap<u32, VecDeque<f64>>,
}

/// The size class of a set of `bytes`: its power of two.
fn size_class(bytes: u64) -> u32 {
    bytes.max(1).ilog2()
}

/// The fastest of `recent`, if any.
fn fastest(recent: &VecDeque<f64>) -> Option<f64> {
    recent.iter().copied().reduce(f64::min)
}

/// Appends a finite positive `value`, forgetting the oldest beyond [`CALIBRATION_WINDOW`].
fn remember(recent: &mut VecDeque<f64>, value: f64) {
    if value.is_finite() && value > 0.0 {
        if recent.len() == CALIBRATION_WINDOW {
            recent.pop_front();
        }
        recent.push_back(value);
    }
}

impl Calibration {
    /// The fastest recent compute reference, if any.
    pub fn baseline_ns(&self) -> Option<f64> {
        fastest(&self.recent)
    }

    pub fn remember(&mut self, compute_ns: f64) {
        remember(&mut self.recent, compute_ns);
    }

    /// The fastest recent plain read of a set of about `bytes`, ns per configuration, if any.
    pub fn stream_baseline_ns(&self, bytes: u64) -> Option<f64> {
        self.streams.get(&size_class(bytes)).and_then(fastest)
    }

    pub fn remember_stream(&mut self, bytes: u64, stream_ns: f64) {
        remember(
            self.streams.entry(size_class(bytes)).or_default(),
            stream_ns,
        );
    }
}

/// The references of one measurement of a point.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct References {
    pub compute_ns_before: f64,
    pub compute_ns_after: f64,
    /// The fastest compute reference of the thread's recent points before this one, if any.
    pub compute_ns_baseline: Option<f64>,
    /// The plain read of the first set and of the last one, each timed after an untimed read
    /// of the fresh set: ns per configuration, the 5th percentile of the read's blocks.
    pub stream_ns_before: f64,
    pub stream_ns_after: f64,
    /// The fastest plain read of sets of this size class on this thread before this point.
    pub stream_ns_baseline: Option<f64>,
    /// The thread's CPU time over the wall time of the timed passes: the share of its core it
    /// had while it was timed (NaN where the system has no thread CPU clock).
    pub core_share: f64,
}

impl References {
    /// Why this measurement is not to be trusted, or `None` if the machine looked steady.
    pub fn disturbance(&self) -> Option<String> {
        if self.core_share < CORE_SHARE_MIN {
            return Some(format!(
                "the timed passes took {:.2}× the CPU time the thread got: another process ran on its core (tolerance {:.2}×)",
                1.0 / self.core_share,
                1.0 / CORE_SHARE_MIN
            ));
        }
        let (before, after) = (self.compute_ns_before, self.compute_ns_after);
        let fastest = self
            .compute_ns_baseline
            .map_or(before.min(after), |b| b.min(before).min(after));
        let slowest = before.max(after);
        if slowest > fastest * COMPUTE_TOLERANCE {
            let what = if after > before { "after" } else { "before" };
            return Some(format!(
                "the core ran {:.2}× slower {what} the point than at its fastest recent reference (tolerance {COMPUTE_TOLERANCE:.2}×)",
                slowest / fastest,
            ));
        }
        let (s0, s1) = (self.stream_ns_before, self.stream_ns_after);
        if s0.max(s1) > s0.min(s1) * STREAM_TOLERANCE {
            let (slow, fast) = if s1 > s0 {
                ("end", "start")
            } else {
                ("start", "end")
            };
            return Some(format!(
                "the plain read of the arrays was {:.2}× slower at the {slow} of the point than at its {fast} (tolerance {STREAM_TOLERANCE:.2}×)",
                s0.max(s1) / s0.min(s1),
            ));
        }
        if let Some(baseline) = self.stream_ns_baseline
            && s0.min(s1) > baseline * STREAM_BASELINE_TOLERANCE
        {
            return Some(format!(
                "the plain read of the arrays was {:.2}× slower than the fastest recent read of sets this size on this core (tolerance {STREAM_BASELINE_TOLERANCE:.2}×)",
                s0.min(s1) / baseline,
            ));
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn references(compute: (f64, f64), baseline: Option<f64>, stream: (f64, f64)) -> References {
        References {
            compute_ns_before: compute.0,
            compute_ns_after: compute.1,
            compute_ns_baseline: baseline,
            stream_ns_before: stream.0,
            stream_ns_after: stream.1,
            stream_ns_baseline: None,
            core_share: 0.999,
        }
    }

    #[test]
    fn steady_references_pass_and_moved_ones_are_flagged_with_the_ratio() {
        assert_eq!(
            references((1.00, 1.02), Some(0.99), (2.0, 2.1)).disturbance(),
            None
        );
        let slow_after = references((1.00, 1.20), Some(1.0), (2.0, 2.0))
            .disturbance()
            .expect("flagged");
        assert!(slow_after.contains("1.20× slower after"), "{slow_after}");
        // Slow from start to end, but slower than this thread's recent points: a long slow phase.
        assert!(
            references((1.2, 1.2), Some(1.0), (2.0, 2.0))
                .disturbance()
                .is_some()
        );
        assert!(
            references((1.2, 1.2), None, (2.0, 2.0))
                .disturbance()
                .is_none()
        );
        let memory = references((1.0, 1.0), None, (2.0, 3.2))
            .disturbance()
            .expect("flagged");
        assert!(memory.contains("1.60× slower at the end"), "{memory}");
        let memory = references((1.0, 1.0), None, (3.4, 2.0))
            .disturbance()
            .expect("flagged");
        assert!(memory.contains("1.70× slower at the start"), "{memory}");
    }

    #[test]
    fn a_thread_that_lost_its_core_is_flagged_whatever_its_references_say() {
        let shared = References {
            core_share: 0.52,
            ..references((1.0, 1.0), Some(1.0), (2.0, 2.0))
        };
        let why = shared.disturbance().expect("flagged");
        assert!(why.contains("1.92× the CPU time"), "{why}");
        // No thread CPU clock: nothing is claimed either way.
        let unknown = References {
            core_share: f64::NAN,
            ..references((1.0, 1.0), Some(1.0), (2.0, 2.0))
        };
        assert_eq!(unknown.disturbance(), None);
    }

    #[test]
    fn a_read_slower_than_recent_reads_of_the_same_size_is_flagged() {
        let mut calibration = Calibration::default();
        calibration.remember_stream(10 << 20, 0.5);
        calibration.remember_stream(100 << 20, 1.8);
        // 12 MiB is in the class of 10 MiB (8 to 16 MiB), not of 100 MiB.
        assert_eq!(calibration.stream_baseline_ns(12 << 20), Some(0.5));
        assert_eq!(calibration.stream_baseline_ns(40 << 20), None);
        let hogged = References {
            stream_ns_baseline: calibration.stream_baseline_ns(12 << 20),
            ..references((1.0, 1.0), None, (0.9, 0.92))
        };
        let why = hogged.disturbance().expect("flagged");
        assert!(
            why.contains("1.80× slower than the fastest recent read"),
            "{why}"
        );
    }

    #[test]
    fn calibration_forgets_after_its_window() {
        let mut calibration = Calibration::default();
        assert_eq!(calibration.baseline_ns(), None);
        calibration.remember(1.0);
        calibration.remember(f64::NAN);
        for _ in 0..CALIBRATION_WINDOW - 1 {
            calibration.remember(1.3);
        }
        assert_eq!(calibration.baseline_ns(), Some(1.0));
        calibration.remember(1.3);
        assert_eq!(
            calibration.baseline_ns(),
            Some(1.3),
            "a lasting change becomes the new normal"
        );
    }

    #[test]
    fn the_compute_reference_is_a_plausible_time() {
        let ns = compute_reference_ns();
        // Two dependent operations per step: at least a cycle at any clock, far below a µs.
        assert!(ns > 0.05 && ns < 100.0, "{ns} ns per step");
    }
}
