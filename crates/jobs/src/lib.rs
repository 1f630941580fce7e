//! Job kinds of `sweep` campaigns: what a point is, what it is called, and how it runs.
//!
//! - [`Plan::parse`] reads a plan (TOML), expands its sweeps into [`JobSpec`]s and validates
//!   every value before anything is scheduled; errors carry file, line, column and key.
//! - [`JobSpec::id`] is a point's identity: BLAKE3 of its canonical JSON (as signac does), so
//!   resubmitting a plan schedules nothing new and extending a list adds only the new points.
//! - [`run()`] runs one job on the calling thread and returns flat records for the store.
//!
//! # Seeds
//! An overlap point's `seed` field is the plan's `seed` (top-level or per sweep, default 0): a
//! parameter like any other, hence part of the id. The configuration generator is seeded with
//! [`JobSpec::generator_seed`], the first 8 bytes of the id's hash, so every point draws its own
//! stream and anyone holding the id can regenerate its configurations.
//!
//! # Records
//! See [`run()`]: an overlap record is a timing if and only if it has an `algorithm` key; the one
//! record without it describes the point (memory floor, generation time, array size, the noise
//! references, whether the machine was disturbed, what the precision cost).
//!
//! This crate knows physics but no network and no database.

mod canonical;
mod child;
mod command;
mod command_plan;
mod plan;
pub mod plugin;
mod run;
mod spec;
mod states;
mod sweep;
mod tune;

pub use child::signal_name;
pub use command::CommandSpec;
pub use plan::{
    MAX_CONFIGURATIONS, MAX_JOBS, MAX_NOOP_DURATION_MS, MAX_REDUCED_LENGTH, MAX_REPEATS,
    MAX_TIME_CAP_S, Plan, PlanError,
};
pub use run::{JobError, Record, run};
pub use spec::{JobSpec, NoopSpec};
pub use tune::{KNOBS, MINIMISED, TuneGoal, TuneSearch, state_point_of};
