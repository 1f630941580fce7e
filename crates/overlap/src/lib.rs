//! Cuboid–sphere overlap detection after Tonti & Patti ("Fast overlap detection between
//! hard-core colloidal cuboids and spheres. The OCSI algorithm"), with the benchmark protocol of
//! their Sec. 3. No I/O: everything here is computation.
//!
//! - [`kernels`]: Arvo (Alg. 1), QRI (Alg. 2), QRF (Alg. 3), SSE-intr (Alg. 4), OCSI (Alg. 5) per
//!   configuration, and `ocsi_batch`, OCSI across configurations; [`min_distance`] is Eq. 2.
//! - [`sampler`]: configurations at a target acceptance ratio (spherocuboid + uniform rotation).
//! - [`protocol`]: the timed loops (in short blocks) and their report; [`estimate`]: robust
//!   estimates, confidence intervals and when to stop measuring; [`noise`]: the references that
//!   tell a disturbed machine.
//! - [`exact`]: Eq. 2 decided exactly; [`verdicts`]: how often each kernel's verdict differs
//!   from it, on a checking set apart from the timed ones (bulk and near-boundary shell);
//!   [`judge`]: one configuration a user gives, judged by every kernel where the precision can
//!   and exactly; [`range`]: what a precision can judge.
//! - [`foreign`]: per-pair kernels of C plugins (`include/sweep_overlap.h`), checked against
//!   Eq. 2 before they are timed, then timed beside the built-in ones.
//!
//! Every kernel is generic over [`Real`] = `f32` | `f64`.

pub mod algorithm;
pub mod batch;
pub mod config;
pub mod error;
pub mod estimate;
pub mod exact;
pub mod foreign;
pub mod judge;
pub mod kernels;
pub mod noise;
pub mod protocol;
pub mod range;
pub mod real;
pub mod rng;
pub mod sampler;
pub mod verdicts;

pub use algorithm::{Algorithm, Precision};
pub use batch::{Batch, BatchView};
pub use config::{Configuration, Cuboid};
pub use error::OverlapError;
pub use estimate::{Estimate, Stop};
pub use foreign::{Foreign, ForeignFn, PluginFile};
pub use kernels::Kernels;
pub use kernels::ocsi::min_distance;
pub use noise::{Calibration, References};
pub use protocol::{
    AlgorithmSummary, Plugins, PointReport, PointSpec, Timing, measure_once, run_point,
    run_point_with,
};
pub use real::Real;

/// Verdict of `algorithm` for one configuration (the batched kernel runs on a batch of one).
pub fn overlaps<T: Kernels>(
    algorithm: Algorithm,
    cfg: &Configuration<T>,
    cuboid: &Cuboid<T>,
    radius: T,
) -> bool {
    match algorithm {
        Algorithm::Arvo => kernels::arvo::arvo(cfg, cuboid, radius),
        Algorithm::Qri => kernels::qri::qri(cfg, cuboid, radius),
        Algorithm::Qrf => kernels::qrf::qrf(cfg, cuboid, radius),
        Algorithm::Sse => T::sse(cfg, cuboid, radius),
        Algorithm::Ocsi => kernels::ocsi::ocsi(cfg, cuboid, radius),
        Algorithm::OcsiBatch => {
            let mut verdict = [0u64];
            T::ocsi_batch(
                Batch::from_configurations(std::slice::from_ref(cfg)).view(),
                cuboid,
                radius,
                &mut verdict,
            );
            verdict[0] & 1 == 1
        }
    }
}
