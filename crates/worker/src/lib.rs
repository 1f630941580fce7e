//! A worker: one slot per core of its budget, each an OS thread pinned to its core, each running
//! one leased job at a time through [`jobs::run`], so timing jobs never share a core. Jobs come
//! from a [`JobQueue`] (the contract in the `queue` crate): a remote coordinator ([`remote`]) or,
//! in local mode, the coordinator embedded in the process (`coordinator::Embedded`). The worker
//! links neither the store nor the scheduler.
//!
//! - [`child`]: jobs that run foreign code (C plugins), run in a child process.
//! - [`provenance`]: what the worker tells the coordinator about its machine and build.
//! - [`slots`]: the pinned threads and the heartbeat that keeps their leases.
//! - [`pace`]: how many jobs a slot leases at once, and when it asks for more.
//! - [`remote`]: the [`JobQueue`] of a coordinator reached over gRPC.

pub mod child;
pub mod pace;
pub mod provenance;
pub mod remote;
pub mod slots;

pub use queue::{JobQueue, QueueError, WorkerInfo};
pub use slots::{Slots, WorkerOptions};

/// Why the slots could not start.
#[derive(Debug, thiserror::Error)]
pub enum WorkerError {
    #[error("core {0} is not available to this process")]
    NoSuchCore(usize),
    #[error("cannot list this machine's cores")]
    NoCores,
    #[error("cannot start a slot thread: {0}")]
    Thread(std::io::Error),
}
