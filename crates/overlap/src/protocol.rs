//! The benchmark protocol of the papers (Sec. 3; Larsson et al.), made to survive a noisy
//! machine: pre-generate N_c configurations, time only each algorithm's loop over the same set,
//! repeat on independent sets, and estimate robustly.
//!
//! - **Blocks.** Each pass of an algorithm over a set is timed in short consecutive blocks
//!   ([`block_configurations`]: at most 16,384 configurations, about half a millisecond for the
//!   slowest kernel), one clock read between two blocks; the pass still streams the whole set
//!   front to back, as the papers time it, so the memory behaviour is unchanged. Every block's
//!   ns/check is kept.
//! - **Interleaving.** Within a set the algorithms run one after the other (A B C), then the
//!   next set (A B C …): a slow phase of the machine hits all of them.
//! - **Robust estimate.** An algorithm's estimate is the 5th percentile of its blocks over
//!   every set (noise only ever adds time), with a 95 % confidence interval
//!   ([`crate::estimate`]).
//! - **Repeat until precise.** With `ci_target`, sets are added until every algorithm's CI
//!   half-width is within it, or until `time_cap_s` of measurement.
//! - **Noise awareness.** Fixed references before and after ([`crate::noise`]); a measurement
//!   made while they moved is re-run, at most [`MAX_RERUNS`] times, and flagged if it still is.
//!
//! A plain read of the same arrays gives the memory-bandwidth floor.

use std::hint::black_box;
use std::ops::Range;
use std::time::Instant;

use cpu_time::ThreadTime;
use serde::{Deserialize, Serialize};

use crate::algorithm::{Algorithm, Precision};
use crate::batch::{Batch, BatchView, Lane, verdict_words};
use crate::config::Cuboid;
use crate::error::OverlapError;
use crate::estimate::{Estimate, Goal, QUANTILE, Stop, estimate, median, quantile};
use crate::foreign::{Foreign, Packed, PluginFile, count_foreign};
use crate::kernels::{Kernels, arvo::arvo, ocsi::ocsi, qrf::qrf, qri::qri};
use crate::noise::{Calibration, References, compute_reference_ns};
use crate::real::Real;
use crate::rng::derive_seed;
use crate::sampler::{Spherocuboid, regenerate};

/// One benchmark point: a cuboid shape, a sphere, an acceptance ratio, and how to time them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointSpec {
    pub l_star: f64,
    pub w_star: f64,
    pub r_star: f64,
    pub acceptance: f64,
    pub configurations: u64,
    pub repeats: u32,
    pub precision: Precision,
    pub algorithms: Vec<Algorithm>,
    pub seed: u64,
    /// Measure more sets until every algorithm's 95 % CI half-width is at most this fraction of
    /// its estimate. Absent from the serialised spec when unset, so points without it keep the
    /// ids they had before it existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ci_target: Option<f64>,
    /// ... or until the measurement has taken this many seconds ([`DEFAULT_TIME_CAP_S`] if
    /// unset); only with `ci_target`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_cap_s: Option<f64>,
    /// Configurations of a checking set, drawn and judged outside the timed loops, whose
    /// verdicts are compared with the exact ones ([`crate::verdicts`]); unset, none, and the
    /// point's id is the one it had before this key existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub verdict_check: Option<u64>,
    /// Which visit of the point this is, when a plan measures it in several visits spread over
    /// the campaign (the plan key `visits`): `None` is the first visit, so a point measured once
    /// keeps the id it had before visits existed, and raising `visits` adds jobs without
    /// touching the done one. Each visit is its own job with its own configuration sets.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub visit: Option<u32>,
    /// C plugins timed beside `algorithms` ([`crate::foreign`]), each by its file and hash.
    /// Absent from the serialised spec when empty, so points without plugins keep their ids.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub plugins: Vec<PluginFile>,
}

fn invalid(key: &'static str, reason: String) -> OverlapError {
    OverlapError::Invalid { key, reason }
}

impl PointSpec {
    /// Every domain check, before any work.
    pub fn validate(&self) -> Result<(), OverlapError> {
        for (key, v) in [
            ("l_star", self.l_star),
            ("w_star", self.w_star),
            ("r_star", self.r_star),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(invalid(
                    key,
                    format!("must be a positive finite number, got {v}"),
                ));
            }
        }
        if !(self.acceptance > 0.0 && self.acceptance < 1.0) {
            return Err(invalid(
                "acceptance",
                format!("must lie strictly between 0 and 1, got {}", self.acceptance),
            ));
        }
        if self.configurations == 0 {
            return Err(invalid("configurations", "must be at least 1".into()));
        }
        if self.repeats == 0 {
            return Err(invalid("repeats", "must be at least 1".into()));
        }
        if self.algorithms.is_empty() {
            return Err(invalid(
                "algorithms",
                "must name at least one algorithm".into(),
            ));
        }
        if let Some(target) = self.ci_target
            && !(target > 0.0 && target < 1.0)
        {
            return Err(invalid(
                "ci_target",
                format!("must lie strictly between 0 and 1, got {target}"),
            ));
        }
        if self.verdict_check == Some(0) {
            return Err(invalid(
                "verdict_check",
                "must be at least 1 configuration (leave it out for none)".into(),
            ));
        }
        if self.visit == Some(0) {
            return Err(invalid(
                "visit",
                "the first visit is written without `visit` (ids must not depend on how it is written)".into(),
            ));
        }
        if let Some(cap) = self.time_cap_s {
            if !(cap.is_finite() && cap > 0.0) {
                return Err(invalid(
                    "time_cap_s",
                    format!("must be a positive number of seconds, got {cap}"),
                ));
            }
            if self.ci_target.is_none() {
                return Err(invalid(
                    "time_cap_s",
                    "caps the time `ci_target` may take: give `ci_target` too".into(),
                ));
            }
        }
        Ok(())
    }

    pub fn spherocuboid(&self) -> Spherocuboid {
        Spherocuboid::for_acceptance(
            [0.5, self.l_star / 2.0, self.w_star / 2.0],
            self.r_star,
            self.acceptance,
        )
    }
}

/// Blocks of a pass hold about this many configurations (see [`block_configurations`]).
const TARGET_BLOCKS: usize = 64;
const MIN_BLOCK_CONFIGURATIONS: usize = 1024;
const MAX_BLOCK_CONFIGURATIONS: usize = 16_384;
/// The most sets one point may have, whatever its `ci_target`.
pub const MAX_REPEATS: u32 = 1000;
/// `time_cap_s` when a point gives a `ci_target` without one.
pub const DEFAULT_TIME_CAP_S: f64 = 60.0;
/// A measurement made on a disturbed machine is repeated at most this many times.
pub const MAX_RERUNS: u32 = 2;

/// Configurations per timed block for a set of `n`: about `n / 64`, between 1,024 and 16,384,
/// a multiple of 64 (a block's verdicts start on a word of the bitset). Blocks of 16,384 run
/// 25 µs (`ocsi_batch`) to 0.6 ms (the slowest per-pair kernel): a clock read (≈ 20 ns) costs
/// at most 0.1 %, and most blocks fall between two time slices of a shared core.
pub fn block_configurations(n: usize) -> usize {
    n.div_ceil(TARGET_BLOCKS)
        .clamp(MIN_BLOCK_CONFIGURATIONS, MAX_BLOCK_CONFIGURATIONS)
        .next_multiple_of(64)
}

/// One pass: one algorithm over one configuration set.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Timing {
    /// A built-in algorithm's name ([`Algorithm::name`]) or a plugin's.
    pub algorithm: String,
    pub repeat: u32,
    /// The set's run time as the robust estimate gives it: `ns_per_check` × N_c.
    pub ms: f64,
    /// ns/check of this pass by the point's statistic: the [`QUANTILE`] of its blocks.
    pub ns_per_check: f64,
    /// Fraction of the set found not overlapping.
    pub acceptance: f64,
    /// The pass from its start to its end, as the papers time it (interruptions included).
    pub total_ms: f64,
    /// ns/check of each block, in order.
    pub block_ns_per_check: Vec<f64>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointReport {
    pub timings: Vec<Timing>,
    /// Median over every block of the plain read of the configuration arrays, per configuration.
    pub stream_ns_per_config: f64,
    /// Wall time spent generating all sets (untimed by the protocol, reported to keep it honest).
    pub generation_ms: f64,
    /// Bytes of one configuration set.
    pub arrays_bytes: u64,
    pub rho: f64,
    pub configurations: u64,
    pub block_configurations: u64,
    /// Sets measured (at least the spec's `repeats`; more when `ci_target` asked for them).
    pub repeats: u32,
    pub stop: Stop,
    /// Time inside the timed loops of the kept measurement.
    pub timed_s: f64,
    /// Wall time of the whole point: generation, references and re-runs included. With
    /// `ci_target`, this is what the precision cost.
    pub wall_s: f64,
    pub references: References,
    /// Why the kept measurement is not to be trusted (the machine was disturbed even after
    /// [`MAX_RERUNS`] re-runs), or `None`.
    pub disturbance: Option<String>,
    /// Measurements thrown away because the machine was disturbed during them.
    pub reruns: u32,
    /// Why each of them was thrown away.
    pub rerun_reasons: Vec<String>,
}

/// An algorithm's result at a point: the robust estimate over the blocks of every set.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AlgorithmSummary {
    /// A built-in algorithm's name or a plugin's.
    pub algorithm: String,
    /// A set's run time by the estimate: `ns_per_check` × N_c.
    pub mean_ms: f64,
    /// The [`QUANTILE`] of the blocks' ns/check over every set ([`crate::estimate`]).
    pub ns_per_check: f64,
    pub acceptance: f64,
    /// The 95 % confidence interval of `ns_per_check`.
    pub ci95_lo_ns_per_check: f64,
    pub ci95_hi_ns_per_check: f64,
    /// The papers' statistic, for comparison: whole passes' time over their checks.
    pub plain_ns_per_check: f64,
}

impl PointReport {
    /// One summary per algorithm, in the order they ran.
    pub fn summary(&self) -> Vec<AlgorithmSummary> {
        let mut algorithms: Vec<&str> = Vec::new();
        for t in &self.timings {
            if !algorithms.contains(&t.algorithm.as_str()) {
                algorithms.push(&t.algorithm);
            }
        }
        algorithms
            .into_iter()
            .map(|algorithm| {
                let runs: Vec<&Timing> = self
                    .timings
                    .iter()
                    .filter(|t| t.algorithm == algorithm)
                    .collect();
                let blocks: Vec<Vec<f64>> =
                    runs.iter().map(|t| t.block_ns_per_check.clone()).collect();
                let nan = Estimate {
                    value: f64::NAN,
                    lo: f64::NAN,
                    hi: f64::NAN,
                    samples: 0,
                    repeats: 0,
                };
                let estimate = estimate(&blocks).unwrap_or(nan);
                let mean = |f: fn(&Timing) -> f64| {
                    runs.iter().map(|t| f(t)).sum::<f64>() / runs.len() as f64
                };
                AlgorithmSummary {
                    algorithm: algorithm.to_owned(),
                    mean_ms: estimate.value * self.configurations as f64 * 1e-6,
                    ns_per_check: estimate.value,
                    acceptance: mean(|t| t.acceptance),
                    ci95_lo_ns_per_check: estimate.lo,
                    ci95_hi_ns_per_check: estimate.hi,
                    plain_ns_per_check: mean(|t| t.total_ms) * 1e6 / self.configurations as f64,
                }
            })
            .collect()
    }
}

/// Untimed plain reads of each fresh set before its timed one.
const WARM_READS: usize = 2;

/// Runs the protocol for one point. Generation uses the current rayon pool; the timed loops run
/// on the calling thread (pin it to a core first), which keeps `calibration` across its points.
/// `on_repeat` is told after each set.
pub fn run_point(
    spec: &PointSpec,
    calibration: &mut Calibration,
    on_repeat: &mut dyn FnMut(u32),
) -> Result<PointReport, OverlapError> {
    run_point_with(spec, &Plugins::default(), calibration, on_repeat)
}

/// The kernels of a point's plugins, loaded by the caller, in the precision the point runs
/// (the other list may stay empty); timed after the built-in algorithms, in this order.
#[derive(Clone, Debug, Default)]
pub struct Plugins {
    pub f32: Vec<Foreign<f32>>,
    pub f64: Vec<Foreign<f64>>,
}

/// [`run_point`] with the point's plugins timed beside its algorithms, on the same sets, in
/// the same blocks, under the same noise checks.
pub fn run_point_with(
    spec: &PointSpec,
    plugins: &Plugins,
    calibration: &mut Calibration,
    on_repeat: &mut dyn FnMut(u32),
) -> Result<PointReport, OverlapError> {
    spec.validate()?;
    rerun_while_disturbed(calibration, |calibration| match spec.precision {
        Precision::F32 => measure::<f32>(spec, &plugins.f32, calibration, on_repeat),
        Precision::F64 => measure::<f64>(spec, &plugins.f64, calibration, on_repeat),
    })
}

/// One measurement of a validated point, with the references around it, judged against what
/// `calibration` remembers but neither re-run nor remembered: what [`run_point`] repeats, and
/// what the noise check's calibration (`examples/noise.rs`) records one by one.
pub fn measure_once(
    spec: &PointSpec,
    calibration: &Calibration,
    on_repeat: &mut dyn FnMut(u32),
) -> Result<PointReport, OverlapError> {
    match spec.precision {
        Precision::F32 => measure::<f32>(spec, &[], calibration, on_repeat),
        Precision::F64 => measure::<f64>(spec, &[], calibration, on_repeat),
    }
}

/// Calls `measure` (given what the thread measured before) until a measurement finds the
/// machine steady, at most 1 + [`MAX_RERUNS`] times, and keeps the last one: flagged with its
/// disturbance if even that was disturbed, with the reasons the others were thrown away.
fn rerun_while_disturbed(
    calibration: &mut Calibration,
    mut measure: impl FnMut(&Calibration) -> Result<PointReport, OverlapError>,
) -> Result<PointReport, OverlapError> {
    let started = Instant::now();
    let mut rerun_reasons = Vec::new();
    loop {
        let mut report = measure(calibration)?;
        let references = &report.references;
        calibration.remember(references.compute_ns_before);
        calibration.remember(references.compute_ns_after);
        calibration.remember_stream(report.arrays_bytes, references.stream_ns_before);
        calibration.remember_stream(report.arrays_bytes, references.stream_ns_after);
        report.disturbance = report.references.disturbance();
        match report.disturbance.take() {
            Some(reason) if rerun_reasons.len() < MAX_RERUNS as usize => rerun_reasons.push(reason),
            disturbance => {
                report.disturbance = disturbance;
                report.reruns = rerun_reasons.len() as u32;
                report.rerun_reasons = rerun_reasons;
                report.wall_s = started.elapsed().as_secs_f64();
                return Ok(report);
            }
        }
    }
}

/// The blocks of one pass: ns per item of each, the whole pass's seconds (wall clock, and the
/// thread's CPU time: NaN without a thread CPU clock), and what the body counted.
struct Pass {
    block_ns: Vec<f64>,
    seconds: f64,
    cpu_seconds: f64,
    count: u64,
}

/// Times `body` over consecutive `ranges`, one clock read between two blocks (no gap between
/// them: the blocks add up to the pass). The thread's CPU clock is read before the first block
/// and after the last, outside every block: a pass that took longer than the CPU time the
/// thread got lost its core to another process for the difference.
#[inline(always)]
fn time_pass(ranges: &[Range<usize>], mut body: impl FnMut(Range<usize>) -> u64) -> Pass {
    let mut block_ns = Vec::with_capacity(ranges.len());
    let mut count = 0;
    let cpu = ThreadTime::try_now().ok();
    let start = Instant::now();
    let mut last = start;
    for range in ranges {
        count += body(range.clone());
        let now = Instant::now();
        block_ns.push((now - last).as_secs_f64() * 1e9 / range.len() as f64);
        last = now;
    }
    let cpu_seconds = cpu
        .and_then(|cpu| cpu.try_elapsed().ok())
        .map_or(f64::NAN, |d| d.as_secs_f64());
    Pass {
        block_ns,
        seconds: (last - start).as_secs_f64(),
        cpu_seconds,
        count,
    }
}

/// One measurement of the point: every set, every algorithm and plugin, the references around
/// them.
fn measure<T: Kernels>(
    spec: &PointSpec,
    plugins: &[Foreign<T>],
    calibration: &Calibration,
    on_repeat: &mut dyn FnMut(u32),
) -> Result<PointReport, OverlapError> {
    let volume = spec.spherocuboid();
    let cuboid = Cuboid::<T>::from_reduced(spec.l_star, spec.w_star);
    let radius = T::from_f64(spec.r_star);
    let n = usize::try_from(spec.configurations).map_err(|_| {
        invalid(
            "configurations",
            format!("{} does not fit in memory", spec.configurations),
        )
    })?;
    let block = block_configurations(n);
    let ranges: Vec<Range<usize>> = (0..n)
        .step_by(block)
        .map(|start| start..(start + block).min(n))
        .collect();
    let goal = Goal {
        min_repeats: spec.repeats,
        ci_target: spec.ci_target,
        time_cap_s: spec.time_cap_s.unwrap_or(DEFAULT_TIME_CAP_S),
        max_repeats: MAX_REPEATS.max(spec.repeats),
    };

    let compute_ns_before = compute_reference_ns();
    let measuring = Instant::now();
    let mut verdicts = vec![0u64; verdict_words(n)];
    let mut batch = Batch::<T>::zeroed(n);
    let arrays_bytes = batch.bytes() as u64;
    let entrants = spec.algorithms.len() + plugins.len();
    let mut timings = Vec::with_capacity(entrants * spec.repeats as usize);
    // Per algorithm (then plugin), per set: the blocks, for the stopping rule.
    let mut blocks: Vec<Vec<Vec<f64>>> = vec![Vec::new(); entrants];
    // The plugins' copy of each set (see `crate::foreign`); none without plugins.
    let mut packed = Packed::<T>::default();
    let (mut generation_ms, mut timed_s, mut timed_cpu_s) = (0.0, 0.0, 0.0);
    let mut stream_blocks = Vec::new();
    let mut stream_ns_first = f64::NAN;
    let mut stream_ns_last;
    let mut repeat = 0;
    let stop = loop {
        let set_started = Instant::now();
        regenerate(
            &mut batch,
            &volume,
            derive_seed(spec.seed, u64::from(repeat)),
        );
        if !plugins.is_empty() {
            packed.fill(&batch);
        }
        generation_ms += set_started.elapsed().as_secs_f64() * 1e3;
        let view = batch.view();

        // A fresh set is dirty in the caches, or in other cores' (the generation wrote it): the
        // first reads pay for writing it back, which no kernel pays (they run after the timed
        // read), and a set in the last-level cache reads steadily from the third read on
        // (measured: 1.0, 0.75, 0.70 ns per configuration for 9.6 MB). So two reads are not
        // timed, and every set's timed read comes at the same moment of its set: the memory
        // references compare the first set's with the last one's.
        for _ in 0..WARM_READS {
            black_box(stream_read(black_box(view)));
            black_box(T::xor_fold(black_box(packed.values())));
        }
        let stream = time_pass(&ranges, |r| stream_read(black_box(view.range(r))));
        black_box(stream.count);
        stream_ns_last = quantile(&stream.block_ns, QUANTILE);
        if repeat == 0 {
            stream_ns_first = stream_ns_last;
        }
        stream_blocks.extend_from_slice(&stream.block_ns);

        let builtins = spec.algorithms.iter().map(|&algorithm| {
            let pass = time_pass(&ranges, |r| {
                let words = &mut verdicts[r.start / 64..][..verdict_words(r.len())];
                count_overlaps(algorithm, black_box(view.range(r)), &cuboid, radius, words)
            });
            (algorithm.name().to_owned(), pass)
        });
        // Run lazily, one after the other, as the loop below asks: the interleaving is unchanged.
        let foreign = plugins.iter().map(|plugin| {
            let pass = time_pass(&ranges, |r| {
                count_foreign(plugin, black_box(packed.range(r)), &cuboid, radius)
            });
            (plugin.name().to_owned(), pass)
        });
        for (a, (algorithm, pass)) in builtins.chain(foreign).enumerate() {
            timed_s += pass.seconds;
            timed_cpu_s += pass.cpu_seconds;
            let ns_per_check = quantile(&pass.block_ns, QUANTILE);
            timings.push(Timing {
                algorithm,
                repeat,
                ms: ns_per_check * n as f64 * 1e-6,
                ns_per_check,
                acceptance: 1.0 - pass.count as f64 / n as f64,
                total_ms: pass.seconds * 1e3,
                block_ns_per_check: pass.block_ns.clone(),
            });
            blocks[a].push(pass.block_ns);
        }
        on_repeat(repeat);
        repeat += 1;
        let worst = match spec.ci_target {
            Some(_) => blocks
                .iter()
                .map(|b| estimate(b).map_or(f64::INFINITY, |e| e.relative_half_width()))
                .fold(0.0, f64::max),
            None => f64::NAN,
        };
        let spent = measuring.elapsed().as_secs_f64();
        if let Some(stop) = goal.next(repeat, worst, spent, set_started.elapsed().as_secs_f64()) {
            break stop;
        }
    };
    let references = References {
        compute_ns_before,
        compute_ns_after: compute_reference_ns(),
        compute_ns_baseline: calibration.baseline_ns(),
        stream_ns_before: stream_ns_first,
        stream_ns_after: stream_ns_last,
        stream_ns_baseline: calibration.stream_baseline_ns(arrays_bytes),
        core_share: timed_cpu_s / timed_s,
    };
    Ok(PointReport {
        timings,
        stream_ns_per_config: median(&stream_blocks),
        generation_ms,
        arrays_bytes,
        rho: volume.rho,
        configurations: spec.configurations,
        block_configurations: block as u64,
        repeats: repeat,
        stop,
        timed_s,
        wall_s: measuring.elapsed().as_secs_f64(),
        references,
        disturbance: None,
        reruns: 0,
        rerun_reasons: Vec::new(),
    })
}

/// The memory floor: every value of the set read once, folded with XOR so nothing is skipped.
#[inline(never)]
pub fn stream_read<T: Real>(batch: BatchView<'_, T>) -> u64 {
    T::xor_fold(batch.values())
}

/// The timed loop. A per-pair kernel is called through a function pointer once per
/// configuration, as the papers' harness calls its overlap function, so the compiler cannot
/// vectorise across configurations and each algorithm is measured as written.
#[inline(never)]
pub fn count_overlaps<'a, T: Kernels>(
    algorithm: Algorithm,
    batch: BatchView<'a, T>,
    cuboid: &Cuboid<T>,
    radius: T,
    verdicts: &mut [u64],
) -> u64 {
    let kernel: fn(&Lane<'a, T>, &Cuboid<T>, T) -> bool = match algorithm {
        Algorithm::Arvo => arvo,
        Algorithm::Qri => qri,
        Algorithm::Qrf => qrf,
        Algorithm::Sse => T::sse,
        Algorithm::Ocsi => ocsi,
        Algorithm::OcsiBatch => {
            T::ocsi_batch(batch, cuboid, radius, verdicts);
            return verdicts.iter().map(|w| w.count_ones() as u64).sum();
        }
    };
    let kernel = black_box(kernel);
    (0..batch.len())
        .map(|i| kernel(&batch.lane(i), cuboid, radius) as u64)
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A measurement whose references are `compute` (before, after) and `stream` (before,
    /// after), as the injected machine would have them; `baseline_ns` is what the protocol
    /// passed in.
    fn measured(
        compute: (f64, f64),
        stream: (f64, f64),
        core_share: f64,
        calibration: &Calibration,
    ) -> PointReport {
        PointReport {
            timings: Vec::new(),
            stream_ns_per_config: stream.0,
            generation_ms: 0.0,
            arrays_bytes: ARRAYS_BYTES,
            rho: 0.0,
            configurations: 1,
            block_configurations: 1,
            repeats: 1,
            stop: Stop::Repeats,
            timed_s: 0.0,
            wall_s: 0.0,
            references: References {
                compute_ns_before: compute.0,
                compute_ns_after: compute.1,
                compute_ns_baseline: calibration.baseline_ns(),
                stream_ns_before: stream.0,
                stream_ns_after: stream.1,
                stream_ns_baseline: calibration.stream_baseline_ns(ARRAYS_BYTES),
                core_share,
            },
            disturbance: None,
            reruns: 0,
            rerun_reasons: Vec::new(),
        }
    }

    /// The size of every set these tests measure.
    const ARRAYS_BYTES: u64 = 12 << 20;

    /// What the machine gives one measurement: (compute, stream) references, each (before,
    /// after), and the share of its core the thread had.
    type Machine = ((f64, f64), (f64, f64), f64);

    const STEADY: Machine = ((1.0, 1.01), (2.0, 2.05), 0.999);

    /// Runs the re-run rule over a machine that gives these references, one per measurement
    /// (the last one repeated): the kept report and how many measurements were made.
    fn run(calibration: &mut Calibration, machine: &[Machine]) -> (PointReport, usize) {
        let mut made = 0;
        let report = rerun_while_disturbed(calibration, |calibration| {
            let (compute, stream, core_share) = machine[made.min(machine.len() - 1)];
            made += 1;
            Ok(measured(compute, stream, core_share, calibration))
        })
        .expect("measures");
        (report, made)
    }

    #[test]
    fn a_steady_machine_is_measured_once() {
        let (report, made) = run(&mut Calibration::default(), &[STEADY]);
        assert_eq!((made, report.reruns, report.disturbance), (1, 0, None));
    }

    #[test]
    fn a_disturbance_during_a_point_is_caught_and_the_point_re_run() {
        // A neighbour takes memory bandwidth during the first measurement only.
        let (report, made) = run(
            &mut Calibration::default(),
            &[((1.0, 1.0), (2.0, 3.2), 0.999), STEADY],
        );
        assert_eq!((made, report.reruns), (2, 1));
        assert_eq!(report.disturbance, None, "the steady re-run is kept");
        assert_eq!(report.references.stream_ns_after, 2.05);
        assert!(
            report.rerun_reasons[0].contains("1.60× slower at the end"),
            "{:?}",
            report.rerun_reasons
        );
    }

    #[test]
    fn a_machine_that_stays_disturbed_is_re_run_at_most_twice_and_flagged() {
        // The core slows down by 20 % during every measurement.
        let (report, made) = run(
            &mut Calibration::default(),
            &[((1.0, 1.2), (2.0, 2.0), 0.999)],
        );
        assert_eq!(made, 1 + MAX_RERUNS as usize);
        assert_eq!(report.reruns, MAX_RERUNS);
        assert_eq!(report.rerun_reasons.len(), MAX_RERUNS as usize);
        let flagged = report.disturbance.expect("flagged");
        assert!(flagged.contains("1.20× slower after"), "{flagged}");
    }

    #[test]
    fn a_slow_phase_longer_than_a_point_is_caught_by_the_calibration() {
        // The thread's earlier points saw a core at 1.0 ns per step; this one runs in a phase
        // 20 % slow from its start to its end, which a before/after comparison cannot see.
        let mut calibration = Calibration::default();
        run(&mut calibration, &[STEADY]);
        let (report, made) = run(&mut calibration, &[((1.2, 1.2), (2.0, 2.0), 0.999), STEADY]);
        assert_eq!((made, report.reruns, report.disturbance), (2, 1, None));
        assert_eq!(report.references.compute_ns_baseline, Some(1.0));
        assert!(
            report.rerun_reasons[0].contains("1.20× slower"),
            "{:?}",
            report.rerun_reasons
        );
    }

    #[test]
    fn a_process_on_the_measuring_core_is_caught_though_the_references_do_not_move() {
        // A busy loop shares the core for good: the median-based references see nothing, the
        // mean of the blocks doubles, and the thread had half its core.
        let (report, made) = run(
            &mut Calibration::default(),
            &[((1.0, 1.0), (2.0, 2.0), 0.5)],
        );
        assert_eq!(made, 1 + MAX_RERUNS as usize);
        let flagged = report.disturbance.expect("flagged");
        assert!(flagged.contains("2.00× the CPU time"), "{flagged}");
    }

    #[test]
    fn a_bandwidth_hog_over_a_whole_point_is_caught_by_the_reads_of_earlier_points() {
        // Steady from start to end but 1.6× slower than this thread's earlier reads of sets of
        // this size: another core took the memory bandwidth for the whole point.
        let mut calibration = Calibration::default();
        run(&mut calibration, &[STEADY]);
        let (report, made) = run(&mut calibration, &[((1.0, 1.0), (3.2, 3.2), 0.999), STEADY]);
        assert_eq!((made, report.reruns, report.disturbance), (2, 1, None));
        assert_eq!(report.references.stream_ns_baseline, Some(2.0));
        assert!(
            report.rerun_reasons[0].contains("1.60× slower than the fastest recent read"),
            "{:?}",
            report.rerun_reasons
        );
    }
}
