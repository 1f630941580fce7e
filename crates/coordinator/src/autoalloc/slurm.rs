//! Slurm, as the allocator sees it: submit an allocation, ask about the ones in flight, cancel
//! one. [`Batch`] is that contract (tests put a fake behind it); [`Slurm`] runs Slurm's own
//! commands (`sbatch --parsable`, `squeue`, `scancel`), each with a deadline, and turns their
//! failures into one line a person can act on.

use std::collections::HashMap;
use std::future::Future;
use std::path::{Path, PathBuf};
use std::time::Duration;

use crate::autoalloc::config::parse_slurm_duration;

/// What Slurm says of one allocation.
#[derive(Debug, Clone, PartialEq)]
pub struct JobStatus {
    /// Slurm's state: PENDING, CONFIGURING, RUNNING, COMPLETING, COMPLETED, FAILED, TIMEOUT,
    /// CANCELLED, NODE_FAIL, …
    pub state: String,
    /// Slurm's reason (why it is pending, or why it ended); `None` is dropped.
    pub reason: String,
    /// Seconds left before its time limit, when Slurm tells.
    pub left_s: Option<f64>,
}

impl JobStatus {
    /// Waiting for its nodes.
    pub fn is_pending(&self) -> bool {
        matches!(
            self.state.as_str(),
            "PENDING" | "REQUEUED" | "REQUEUE_HOLD" | "REQUEUE_FED" | "RESV_DEL_HOLD" | "SUSPENDED"
        )
    }

    /// Its nodes are its own (or being set up or released).
    pub fn is_running(&self) -> bool {
        matches!(
            self.state.as_str(),
            "RUNNING" | "CONFIGURING" | "COMPLETING" | "STAGE_OUT" | "SIGNALING" | "RESIZING"
        )
    }
}

/// The batch system behind the allocator.
pub trait Batch: Send + Sync + 'static {
    /// Submits `sbatch ARGS`; answers the new job's id, or why it was refused (one line).
    fn submit(&self, args: &[String]) -> impl Future<Output = Result<String, String>> + Send;
    /// The status of the jobs `ids`. An id missing from the answer is not known to Slurm any
    /// more (it ended long enough ago to be forgotten).
    fn query(
        &self,
        ids: &[String],
    ) -> impl Future<Output = Result<HashMap<String, JobStatus>, String>> + Send;
    /// Cancels job `id`.
    fn cancel(&self, id: &str) -> impl Future<Output = Result<(), String>> + Send;
}

/// Slurm's commands, found on PATH unless named.
#[derive(Debug, Clone)]
pub struct Slurm {
    pub sbatch: PathBuf,
    pub squeue: PathBuf,
    pub scancel: PathBuf,
}

impl Default for Slurm {
    fn default() -> Self {
        Slurm {
            sbatch: "sbatch".into(),
            squeue: "squeue".into(),
            scancel: "scancel".into(),
        }
    }
}

impl Slurm {
    /// The commands that cannot be found (on PATH, or at the path given): the allocator cannot
    /// start without them.
    pub fn missing(&self) -> Vec<String> {
        [&self.sbatch, &self.squeue, &self.scancel]
            .into_iter()
            .filter(|program| !runnable(program))
            .map(|program| program.display().to_string())
            .collect()
    }
}

/// Whether `program` is an executable file, looked up on PATH when it has no directory.
fn runnable(program: &Path) -> bool {
    use std::os::unix::fs::PermissionsExt;
    let executable = |path: &Path| {
        path.metadata()
            .is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
    };
    if program.components().count() > 1 {
        return executable(program);
    }
    std::env::var_os("PATH")
        .is_some_and(|path| std::env::split_paths(&path).any(|dir| executable(&dir.join(program))))
}

/// A Slurm command that takes longer than this is given up (slurmctld busy or away).
const DEADLINE: Duration = Duration::from_secs(60);

/// Runs `program args`: its stdout, or one line saying why it failed (its stderr, joined).
async fn run(program: &PathBuf, args: &[String]) -> Result<String, String> {
    let name = program.display();
    let mut command = tokio::process::Command::new(program);
    command.args(args).kill_on_drop(true);
    let output = match tokio::time::timeout(DEADLINE, command.output()).await {
        Err(_) => {
            return Err(format!(
                "{name} did not answer within {} s",
                DEADLINE.as_secs()
            ));
        }
        Ok(Err(error)) => return Err(format!("cannot run {name}: {error}")),
        Ok(Ok(output)) => output,
    };
    if output.status.success() {
        return Ok(String::from_utf8_lossy(&output.stdout).into_owned());
    }
    let said = one_line(&String::from_utf8_lossy(&output.stderr));
    Err(if said.is_empty() {
        format!("{name} failed ({})", output.status)
    } else {
        said
    })
}

/// Non-empty lines joined with ` / `: a message of several lines as one.
pub fn one_line(text: &str) -> String {
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join(" / ")
}

/// `squeue --format` of [`parse_squeue`].
const SQUEUE_FORMAT: &str = "%i|%T|%L|%r";

/// Lines `ID|STATE|TIME_LEFT|REASON` of `squeue --noheader --format=%i|%T|%L|%r`.
pub fn parse_squeue(out: &str) -> HashMap<String, JobStatus> {
    out.lines()
        .filter_map(|line| {
            let mut fields = line.trim().splitn(4, '|');
            let id = fields.next()?.trim();
            let state = fields.next()?.trim();
            if id.is_empty() || state.is_empty() {
                return None;
            }
            let left_s = fields
                .next()
                .and_then(|l| parse_slurm_duration(l.trim()).ok());
            let reason = fields
                .next()
                .map(str::trim)
                .filter(|r| *r != "None" && *r != "(null)")
                .unwrap_or_default();
            // "CANCELLED by 0" in some versions' %T.
            let state = state.split_whitespace().next().unwrap_or(state);
            Some((
                id.to_owned(),
                JobStatus {
                    state: state.to_owned(),
                    reason: reason.to_owned(),
                    left_s,
                },
            ))
        })
        .collect()
}

impl Batch for Slurm {
    async fn submit(&self, args: &[String]) -> Result<String, String> {
        let out = run(&self.sbatch, args).await?;
        // --parsable: "ID" or "ID;CLUSTER".
        let id = out.trim().split(';').next().unwrap_or_default().trim();
        if id.is_empty() || !id.bytes().all(|b| b.is_ascii_digit() || b == b'_') {
            return Err(format!(
                "{} answered {:?}, not a job id",
                self.sbatch.display(),
                one_line(&out)
            ));
        }
        Ok(id.to_owned())
    }

    async fn query(&self, ids: &[String]) -> Result<HashMap<String, JobStatus>, String> {
        if ids.is_empty() {
            return Ok(HashMap::new());
        }
        let args = vec![
            "--noheader".to_owned(),
            "--states=all".to_owned(),
            format!("--jobs={}", ids.join(",")),
            format!("--format={SQUEUE_FORMAT}"),
        ];
        match run(&self.squeue, &args).await {
            Ok(out) => Ok(parse_squeue(&out)),
            // Asked about one job only, squeue fails when Slurm has forgotten it.
            Err(error) if ids.len() == 1 && error.contains("Invalid job id") => Ok(HashMap::new()),
            Err(error) => Err(error),
        }
    }

    async fn cancel(&self, id: &str) -> Result<(), String> {
        run(&self.scancel, &[id.to_owned()]).await.map(drop)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn squeue_lines() {
        let out =
            "12|RUNNING|1:59|None\n13|PENDING|2:00:00|Resources\n14|CANCELLED by 0|1:30|None\n\n";
        let jobs = parse_squeue(out);
        assert_eq!(jobs.len(), 3);
        assert_eq!(jobs["12"].left_s, Some(119.0));
        assert!(jobs["12"].is_running());
        assert_eq!(jobs["13"].reason, "Resources");
        assert!(jobs["13"].is_pending());
        assert_eq!(jobs["14"].state, "CANCELLED");
        assert!(!jobs["14"].is_pending() && !jobs["14"].is_running());
        assert_eq!(
            parse_squeue("15|PENDING|UNLIMITED|Priority")["15"].left_s,
            None
        );
    }

    #[test]
    fn messages_become_one_line() {
        assert_eq!(
            one_line(
                "sbatch: error: invalid partition specified: nope\n\
                 sbatch: error: Batch job submission failed: Invalid partition name specified\n"
            ),
            "sbatch: error: invalid partition specified: nope / sbatch: error: Batch job \
             submission failed: Invalid partition name specified"
        );
    }
}
