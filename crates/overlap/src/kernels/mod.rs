//! The overlap tests. Per-pair kernels (`arvo`, `qri`, `qrf`, `sse`, `ocsi`) follow the papers'
//! pseudocode line by line and answer "do sphere and cuboid overlap?" for one configuration;
//! `batch` is OCSI across many configurations at once.

pub mod arvo;
pub mod batch;
pub mod ocsi;
pub mod qrf;
pub mod qri;
pub mod sse;

use crate::batch::BatchView;
use crate::config::{ConfigurationView, Cuboid};
use crate::real::Real;
use batch::Isa;

/// The kernels that exist in one precision only, as SIMD code: which one `T` runs.
pub trait Kernels: Real {
    /// Algorithm 4 (SSE-intr) in this precision; see [`sse`].
    fn sse(cfg: &impl ConfigurationView<Self>, cuboid: &Cuboid<Self>, radius: Self) -> bool;

    /// OCSI across configurations on instruction set `isa`, see [`batch`].
    fn ocsi_batch_on(
        isa: Isa,
        batch: BatchView<'_, Self>,
        cuboid: &Cuboid<Self>,
        radius: Self,
        verdicts: &mut [u64],
    );

    /// OCSI across configurations on the best instruction set of this CPU.
    fn ocsi_batch(
        batch: BatchView<'_, Self>,
        cuboid: &Cuboid<Self>,
        radius: Self,
        verdicts: &mut [u64],
    ) {
        Self::ocsi_batch_on(Isa::best(), batch, cuboid, radius, verdicts)
    }
}

impl Kernels for f32 {
    #[inline(always)]
    fn sse(cfg: &impl ConfigurationView<Self>, cuboid: &Cuboid<Self>, radius: Self) -> bool {
        sse::sse_f32(cfg, cuboid, radius)
    }
    fn ocsi_batch_on(
        isa: Isa,
        batch: BatchView<'_, Self>,
        cuboid: &Cuboid<Self>,
        radius: Self,
        verdicts: &mut [u64],
    ) {
        batch::ocsi_batch_f32(isa, batch, cuboid, radius, verdicts)
    }
}

impl Kernels for f64 {
    #[inline(always)]
    fn sse(cfg: &impl ConfigurationView<Self>, cuboid: &Cuboid<Self>, radius: Self) -> bool {
        sse::sse_f64(cfg, cuboid, radius)
    }
    fn ocsi_batch_on(
        isa: Isa,
        batch: BatchView<'_, Self>,
        cuboid: &Cuboid<Self>,
        radius: Self,
        verdicts: &mut [u64],
    ) {
        batch::ocsi_batch_f64(isa, batch, cuboid, radius, verdicts)
    }
}
