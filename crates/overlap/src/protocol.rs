//! The benchmark protocol of the papers (Sec. 3; Larsson et al.): pre-generate N_c
//! configurations, time only each algorithm's loop over the same set, repeat on independent
//! sets, report the mean. A plain read of the same arrays gives the memory-bandwidth floor.

use std::hint::black_box;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::algorithm::{Algorithm, Precision};
use crate::batch::{Batch, Lane, verdict_words};
use crate::config::Cuboid;
use crate::error::OverlapError;
use crate::kernels::{arvo::arvo, ocsi::ocsi, qrf::qrf, qri::qri};
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
}

fn invalid(key: &'static str, reason: String) -> OverlapError {
    OverlapError::Invalid { key, reason }
}

impl PointSpec {
    /// Every domain check, before any work.
    pub fn validate(&self) -> Result<(), OverlapError> {
        for (key, v) in [("l_star", self.l_star), ("w_star", self.w_star), ("r_star", self.r_star)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(invalid(key, format!("must be a positive finite number, got {v}")));
            }
        }
        if !(self.acceptance > 0.0 && self.acceptance < 1.0) {
            return Err(invalid("acceptance", format!("must lie strictly between 0 and 1, got {}", self.acceptance)));
        }
        if self.configurations == 0 {
            return Err(invalid("configurations", "must be at least 1".into()));
        }
        if self.repeats == 0 {
            return Err(invalid("repeats", "must be at least 1".into()));
        }
        if self.algorithms.is_empty() {
            return Err(invalid("algorithms", "must name at least one algorithm".into()));
        }
        Ok(())
    }

    pub fn spherocuboid(&self) -> Spherocuboid {
        Spherocuboid::for_acceptance([0.5, self.l_star / 2.0, self.w_star / 2.0], self.r_star, self.acceptance)
    }
}

/// One timed loop: one algorithm over one configuration set.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Timing {
    pub algorithm: Algorithm,
    pub repeat: u32,
    pub ms: f64,
    pub ns_per_check: f64,
    /// Fraction of the set found not overlapping.
    pub acceptance: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PointReport {
    pub timings: Vec<Timing>,
    /// Mean over repeats of a plain read of the configuration arrays, per configuration.
    pub stream_ns_per_config: f64,
    /// Wall time spent generating all sets (untimed by the protocol, reported to keep it honest).
    pub generation_ms: f64,
    /// Bytes of one configuration set.
    pub arrays_bytes: u64,
    pub rho: f64,
}

/// The papers' table entry: an algorithm's mean over repeats.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AlgorithmSummary {
    pub algorithm: Algorithm,
    pub mean_ms: f64,
    pub ns_per_check: f64,
    pub acceptance: f64,
}

impl PointReport {
    pub fn summary(&self) -> Vec<AlgorithmSummary> {
        let mut algorithms: Vec<Algorithm> = Vec::new();
        for t in &self.timings {
            if !algorithms.contains(&t.algorithm) {
                algorithms.push(t.algorithm);
            }
        }
        algorithms
            .into_iter()
            .map(|algorithm| {
                let runs: Vec<&Timing> = self.timings.iter().filter(|t| t.algorithm == algorithm).collect();
                let mean = |f: fn(&Timing) -> f64| runs.iter().map(|t| f(t)).sum::<f64>() / runs.len() as f64;
                AlgorithmSummary {
                    algorithm,
                    mean_ms: mean(|t| t.ms),
                    ns_per_check: mean(|t| t.ns_per_check),
                    acceptance: mean(|t| t.acceptance),
                }
            })
            .collect()
    }
}

/// Runs the protocol for one point. Generation uses the current rayon pool; the timed loops run
/// on the calling thread (pin it to a core first). `on_repeat` is told after each repeat.
pub fn run_point(spec: &PointSpec, on_repeat: &mut dyn FnMut(u32)) -> Result<PointReport, OverlapError> {
    spec.validate()?;
    match spec.precision {
        Precision::F32 => run_typed::<f32>(spec, on_repeat),
        Precision::F64 => run_typed::<f64>(spec, on_repeat),
    }
}

fn run_typed<T: Real>(spec: &PointSpec, on_repeat: &mut dyn FnMut(u32)) -> Result<PointReport, OverlapError> {
    let volume = spec.spherocuboid();
    let cuboid = Cuboid::<T>::from_reduced(spec.l_star, spec.w_star);
    let radius = T::from_f64(spec.r_star);
    let n = usize::try_from(spec.configurations)
        .map_err(|_| invalid("configurations", format!("{} does not fit in memory", spec.configurations)))?;
    let mut timings = Vec::with_capacity(spec.algorithms.len() * spec.repeats as usize);
    let (mut generation_ms, mut stream_ns) = (0.0, 0.0);
    let mut verdicts = vec![0u64; verdict_words(n)];
    let mut batch = Batch::<T>::zeroed(n);
    let arrays_bytes = batch.bytes() as u64;
    for repeat in 0..spec.repeats {
        let started = Instant::now();
        regenerate(&mut batch, &volume, derive_seed(spec.seed, repeat as u64));
        generation_ms += started.elapsed().as_secs_f64() * 1e3;

        let started = Instant::now();
        black_box(stream_read(black_box(&batch)));
        stream_ns += started.elapsed().as_secs_f64() * 1e9 / n as f64;

        for &algorithm in &spec.algorithms {
            let started = Instant::now();
            let overlaps = count_overlaps(algorithm, black_box(&batch), &cuboid, radius, &mut verdicts);
            let seconds = started.elapsed().as_secs_f64();
            timings.push(Timing {
                algorithm,
                repeat,
                ms: seconds * 1e3,
                ns_per_check: seconds * 1e9 / n as f64,
                acceptance: 1.0 - overlaps as f64 / n as f64,
            });
        }
        on_repeat(repeat);
    }
    Ok(PointReport {
        timings,
        stream_ns_per_config: stream_ns / spec.repeats as f64,
        generation_ms,
        arrays_bytes,
        rho: volume.rho,
    })
}

/// The memory floor: every value of the set read once, folded with XOR so nothing is skipped.
#[inline(never)]
pub fn stream_read<T: Real>(batch: &Batch<T>) -> u64 {
    T::xor_fold(batch.values())
}

/// The timed loop. A per-pair kernel is called through a function pointer once per
/// configuration, as the papers' harness calls its overlap function, so the compiler cannot
/// vectorise across configurations and each algorithm is measured as written.
#[inline(never)]
pub fn count_overlaps<'a, T: Real>(
    algorithm: Algorithm,
    batch: &'a Batch<T>,
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
    (0..batch.len()).map(|i| kernel(&batch.lane(i), cuboid, radius) as u64).sum()
}
