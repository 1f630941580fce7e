//! Paths of the overlap plugins the tests use, built by `build.rs` from C:
//! the examples of `plugins/example` (OCSI and Arvo as the paper writes them) and plugins that
//! are broken on purpose.

/// OCSI (Algorithm 5) in C, both precisions, named `c_ocsi`.
pub const C_OCSI: &str = concat!(env!("OUT_DIR"), "/libc_ocsi.so");
/// Arvo (Algorithm 1) in C, both precisions, named `c_arvo`.
pub const C_ARVO: &str = concat!(env!("OUT_DIR"), "/libc_arvo.so");
/// Says every pair overlaps: wrong.
pub const ALWAYS_OVERLAP: &str = concat!(env!("OUT_DIR"), "/libalways_overlap.so");
/// Writes through a null pointer on its first call.
pub const SEGFAULT: &str = concat!(env!("OUT_DIR"), "/libsegfault.so");
/// OCSI in f64 only: no `sweep_overlap_f32`.
pub const F64_ONLY: &str = concat!(env!("OUT_DIR"), "/libf64_only.so");
