//! The overlap tests. Per-pair kernels (`arvo`, `qri`, `qrf`, `sse`, `ocsi`) follow the papers'
//! pseudocode line by line and answer "do sphere and cuboid overlap?" for one configuration;
//! `batch` is OCSI across many configurations at once.

pub mod arvo;
pub mod batch;
pub mod ocsi;
pub mod qrf;
pub mod qri;
pub mod sse;
