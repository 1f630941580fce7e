//! The results layer: the one place that knows what the stored result records of each kind of
//! job contain, and how they become the rows the `report` crate draws and tabulates.
//!
//! The store returns jobs and their records as opaque JSON; `jobs::run` writes them. This crate
//! reads them back — a job's parameters as the [`jobs::JobSpec`] they were written as, its
//! records through the fields reports use (fields written only by later versions may be
//! absent, so older databases stay readable) — and returns `report`'s rows. `sweep report`, `sweep
//! status` and the status page all read through it, so they cannot drift apart.
//!
//! Map of the crate:
//! - `overlap`: [`overlap_visits`] (one row per job and algorithm, with every block) and
//!   [`overlap_verdicts`] (the verdict checks of the accuracy report).
//! - `points`: [`overlap_points`], the rows of Tables 1–2 and Figs. 2–3: each visit
//!   re-estimated from its blocks by a statistic, a point's visits pooled.
//! - `edmd`: [`edmd_runs`] (Figs. 7–11, 13, the accuracy report) and [`failed_edmd_runs`].
//! - `command`: [`command_runs`], the done program jobs (`[[command]]`) with their values.
//! - `quality`: [`overlap_quality`], how a campaign's overlap points were measured;
//!   `history`: [`machine_history`], campaigns slower than the same machine's earlier ones.
//!
//! Every function reads through the store's read-only connections; none writes. Stored data
//! that lacks what its kind writes is an [`Error::Corrupt`] naming the job, never skipped.

mod command;
mod edmd;
mod error;
mod history;
mod overlap;
mod points;
mod quality;

/// The statistic a point's estimate is made by (`overlap::estimate`).
pub use ::overlap::estimate::Statistic;
pub use command::command_runs;
pub use edmd::{edmd_runs, edmd_scenes, edmd_unfinished_scenes, failed_edmd_runs};
pub use error::{Error, Result};
pub use history::{MachineShift, machine_history};
pub use overlap::{OverlapVisit, overlap_verdicts, overlap_visits};
pub use points::overlap_points;
pub use quality::{OverlapQuality, overlap_quality};
