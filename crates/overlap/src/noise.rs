//! Is the machine disturbed? Two fixed references measured before and after each point, and
//! the rule that flags a point measured while they moved.
//!
//! - The **compute reference**: a fixed chain of dependent integer operations (no memory
//!   traffic, no branches to predict), timed in short blocks, median ns per step. It moves when
//!   the core itself gets slower: a lower clock, a busy SMT sibling, a hypervisor's steal.
//!   Time slices lost to another process do not move it (the median skips the blocks they hit),
//!   and the protocol's own median already absorbs those.
//! - The **memory reference**: the plain read of the configuration arrays that the protocol
//!   times anyway (`stream_ns_per_config`), before the first set and after the last. It moves
//!   when another process takes memory bandwidth.
//!
//! A point is flagged when a reference moved by more than its tolerance during the point, or
//! when the compute reference is slower than the fastest this thread measured over its recent
//! points ([`Calibration`]): a slow phase that covers a whole point is invisible to a
//! before/after comparison.

use std::collections::VecDeque;
use std::hint::black_box;
use std::time::Instant;

/// Steps of the compute loop per timed block (about 10 µs on a 3 GHz core): short enough that
/// few blocks are hit by a scheduler tick or a time slice given away.
const COMPUTE_STEPS_PER_BLOCK: u64 = 8192;
/// Blocks of the compute reference: about 1.5 ms in all.
const COMPUTE_BLOCKS: usize = 128;
/// The compute reference may differ by this much (relative) from the fastest recent one.
pub const COMPUTE_TOLERANCE: f64 = 0.05;
/// The memory reference may differ by this much between the start and the end of a point
/// (memory bandwidth is noisier than a core's clock).
pub const STREAM_TOLERANCE: f64 = 0.15;
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
}

impl Calibration {
    /// The fastest recent compute reference, if any.
    pub fn baseline_ns(&self) -> Option<f64> {
        self.recent.iter().copied().reduce(f64::min)
    }

    pub fn remember(&mut self, compute_ns: f64) {
        if compute_ns.is_finite() && compute_ns > 0.0 {
            if self.recent.len() == CALIBRATION_WINDOW {
                self.recent.pop_front();
            }
            self.recent.push_back(compute_ns);
        }
    }
}

/// The references of one measurement of a point.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct References {
    pub compute_ns_before: f64,
    pub compute_ns_after: f64,
    /// The fastest compute reference of the thread's recent points before this one, if any.
    pub compute_ns_baseline: Option<f64>,
    /// Plain read of the arrays, ns per configuration.
    pub stream_ns_before: f64,
    pub stream_ns_after: f64,
}

impl References {
    /// Why this measurement is not to be trusted, or `None` if the machine looked steady.
    pub fn disturbance(&self) -> Option<String> {
        let (before, after) = (self.compute_ns_before, self.compute_ns_after);
        let fastest = self
            .compute_ns_baseline
            .map_or(before.min(after), |b| b.min(before).min(after));
        let slowest = before.max(after);
        if slowest > fastest * (1.0 + COMPUTE_TOLERANCE) {
            let (what, slow) = if after > before {
                ("after", after)
            } else {
                ("before", before)
            };
            return Some(format!(
                "the core ran {:.1} % slower {what} the point than at its fastest recent reference (tolerance {:.0} %)",
                (slow / fastest - 1.0) * 100.0,
                COMPUTE_TOLERANCE * 100.0
            ));
        }
        let (s0, s1) = (self.stream_ns_before, self.stream_ns_after);
        if s0.max(s1) > s0.min(s1) * (1.0 + STREAM_TOLERANCE) {
            return Some(format!(
                "the plain read of the arrays took {:.1} % {} at the end of the point than at its start (tolerance {:.0} %)",
                (s0.max(s1) / s0.min(s1) - 1.0) * 100.0,
                if s1 > s0 { "longer" } else { "less" },
                STREAM_TOLERANCE * 100.0
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
        }
    }

    #[test]
    fn steady_references_pass_and_moved_ones_are_flagged() {
        assert_eq!(
            references((1.00, 1.02), Some(0.99), (2.0, 2.1)).disturbance(),
            None
        );
        let slow_after = references((1.00, 1.10), Some(1.0), (2.0, 2.0))
            .disturbance()
            .expect("flagged");
        assert!(slow_after.contains("10.0 % slower after"), "{slow_after}");
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
        let memory = references((1.0, 1.0), None, (2.0, 2.5))
            .disturbance()
            .expect("flagged");
        assert!(memory.contains("25.0 % longer"), "{memory}");
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
