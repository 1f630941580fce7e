//! The allocation file of `sweep coordinator --slurm-alloc FILE` (TOML): what one allocation asks
//! Slurm for, how many may be in flight, and when its workers stop. Every key but `time_limit` and
//! `cores` has a default; an unknown key, a wrong type or a value out of range is refused with the
//! file, line, column and key, before the coordinator starts.
//!
//! ```toml
//! time_limit = "2:00:00"      # sbatch --time (Slurm's formats: MM, MM:SS, HH:MM:SS, D-HH, D-HH:MM, D-HH:MM:SS)
//! cores = 16                  # cores per allocation, all its nodes together
//! nodes = 1                   # nodes per allocation (one worker each)
//! max_in_flight = 4           # allocations pending or running at once
//! idle_timeout_s = 300        # a worker with no job for this long stops, ending its allocation
//! stop_margin_s = 120         # workers finish their jobs this long before the time limit
//! partition = "compute"       # sbatch --partition
//! account = "project42"       # sbatch --account
//! sbatch_args = ["--qos=normal", "--exclusive"]   # anything else sbatch should get
//! worker_args = ["--ca", "/shared/ca.crt"]        # extra `sweep worker` flags
//! coordinator_url = "http://login1:7070"          # how the nodes reach this coordinator
//! directory = "allocations"   # the allocations' working directory and output files
//! script = "sweep.sbatch"     # default: the sweep.sbatch built into this binary
//! sweep = "/shared/bin/sweep" # the binary on the nodes (default: this one)
//! check_every_s = 30          # how often squeue is asked about the allocations in flight
//! ```
//!
//! Relative paths are relative to the file's folder.

use std::ops::Range;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::Spanned;

/// What the allocation file asks for, checked.
#[derive(Debug, Clone, PartialEq)]
pub struct AllocConfig {
    /// The file it was read from (for messages).
    pub file: PathBuf,
    /// As written, for sbatch `--time`.
    pub time_limit: String,
    pub time_limit_s: f64,
    pub nodes: u32,
    /// Cores per allocation (a multiple of `nodes`).
    pub cores: u32,
    pub max_in_flight: u32,
    pub idle_timeout_s: u64,
    pub stop_margin_s: u64,
    pub partition: Option<String>,
    pub account: Option<String>,
    pub sbatch_args: Vec<String>,
    pub worker_args: Vec<String>,
    pub coordinator_url: Option<String>,
    /// Absolute.
    pub directory: PathBuf,
    /// Absolute; `None`: the script built into the binary.
    pub script: Option<PathBuf>,
    /// Absolute; `None`: the running binary.
    pub sweep: Option<PathBuf>,
    pub check_every_s: u64,
}

impl AllocConfig {
    /// Seconds of an allocation its workers may run jobs in: the time limit less the margin.
    pub fn usable_s(&self) -> f64 {
        self.time_limit_s - self.stop_margin_s as f64
    }

    /// Cores of each node of an allocation.
    pub fn cores_per_node(&self) -> u32 {
        self.cores / self.nodes
    }

    /// Reads and checks the file at `path`.
    pub fn read(path: &Path) -> Result<AllocConfig, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|e| ConfigError {
            file: path.display().to_string(),
            line: 0,
            column: 0,
            key: None,
            message: e.to_string(),
        })?;
        // The folder of `alloc.toml` is "": the current directory. Paths go to sbatch, which
        // resolves them against the allocation's working directory: they must be absolute.
        let folder = match path.parent() {
            Some(parent) if !parent.as_os_str().is_empty() => parent,
            _ => Path::new("."),
        };
        let folder = std::path::absolute(folder).map_err(|e| ConfigError {
            file: path.display().to_string(),
            line: 0,
            column: 0,
            key: None,
            message: format!("cannot tell its folder: {e}"),
        })?;
        AllocConfig::parse(&text, path, &folder)
    }

    /// Checks `text` (the file `path`); relative paths are taken from `folder`.
    pub fn parse(text: &str, path: &Path, folder: &Path) -> Result<AllocConfig, ConfigError> {
        let locate = |issue: Issue| issue.locate(text, path);
        let file: File = toml::from_str(text).map_err(|e| {
            locate(Issue {
                span: e.span().unwrap_or(0..0),
                key: None,
                message: e.message().to_owned(),
            })
        })?;
        file.check(path, folder).map_err(locate)
    }
}

/// A refused allocation file. Displays as one line: `FILE:LINE:COL: key `k`: reason`.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{file}:{line}:{column}: {}{message}", key.as_ref().map(|k| format!("key `{k}`: ")).unwrap_or_default())]
pub struct ConfigError {
    pub file: String,
    /// 1-based (0: the file could not be read).
    pub line: usize,
    pub column: usize,
    pub key: Option<String>,
    pub message: String,
}

/// A problem at a place of the text.
struct Issue {
    span: Range<usize>,
    key: Option<&'static str>,
    message: String,
}

impl Issue {
    fn at<T>(value: &Spanned<T>, key: &'static str, message: impl Into<String>) -> Issue {
        Issue {
            span: value.span(),
            key: Some(key),
            message: message.into(),
        }
    }

    fn locate(self, text: &str, path: &Path) -> ConfigError {
        let before = text.get(..self.span.start.min(text.len())).unwrap_or(text);
        ConfigError {
            file: path.display().to_string(),
            line: before.matches('\n').count() + 1,
            column: before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1,
            key: self.key.map(str::to_owned),
            message: self
                .message
                .split_whitespace()
                .collect::<Vec<_>>()
                .join(" "),
        }
    }
}

/// The file as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    time_limit: Spanned<String>,
    cores: Spanned<i64>,
    nodes: Option<Spanned<i64>>,
    max_in_flight: Option<Spanned<i64>>,
    idle_timeout_s: Option<Spanned<i64>>,
    stop_margin_s: Option<Spanned<i64>>,
    partition: Option<Spanned<String>>,
    account: Option<Spanned<String>>,
    #[serde(default)]
    sbatch_args: Vec<Spanned<String>>,
    #[serde(default)]
    worker_args: Vec<String>,
    coordinator_url: Option<Spanned<String>>,
    directory: Option<String>,
    script: Option<Spanned<String>>,
    sweep: Option<String>,
    check_every_s: Option<Spanned<i64>>,
}

/// Defaults of the optional keys.
pub const DEFAULT_IDLE_TIMEOUT_S: u64 = 300;
pub const DEFAULT_STOP_MARGIN_S: u64 = 120;
pub const DEFAULT_CHECK_EVERY_S: u64 = 30;

/// sbatch options the allocator sets itself: given in `sbatch_args` they would contradict it.
const OWN_OPTIONS: &[&str] = &[
    "--time",
    "-t",
    "--nodes",
    "-N",
    "--cpus-per-task",
    "-c",
    "--ntasks-per-node",
    "--output",
    "-o",
    "--chdir",
    "-D",
    "--parsable",
    "--signal",
    "--export",
    "--partition",
    "-p",
    "--account",
    "-A",
];

fn integer(
    value: &Option<Spanned<i64>>,
    key: &'static str,
    default: u64,
    least: u64,
) -> Result<u64, Issue> {
    let Some(value) = value else {
        return Ok(default);
    };
    match u64::try_from(*value.get_ref()) {
        Ok(n) if n >= least => Ok(n),
        _ => Err(Issue::at(
            value,
            key,
            format!(
                "must be an integer of at least {least}, got {}",
                value.get_ref()
            ),
        )),
    }
}

fn small(n: u64, value: &Option<Spanned<i64>>, key: &'static str) -> Result<u32, Issue> {
    u32::try_from(n).map_err(|_| match value {
        Some(v) => Issue::at(v, key, format!("{n} is too large")),
        None => Issue {
            span: 0..0,
            key: Some(key),
            message: format!("{n} is too large"),
        },
    })
}

fn absolute(folder: &Path, path: &str) -> PathBuf {
    let path = Path::new(path);
    if path.is_absolute() {
        path.to_owned()
    } else {
        folder.join(path)
    }
}

impl File {
    fn check(self, path: &Path, folder: &Path) -> Result<AllocConfig, Issue> {
        let time_limit_s = parse_slurm_duration(self.time_limit.get_ref())
            .map_err(|why| Issue::at(&self.time_limit, "time_limit", why))?;
        let nodes = small(integer(&self.nodes, "nodes", 1, 1)?, &self.nodes, "nodes")?;
        let cores_value = Some(self.cores.clone());
        let cores = small(integer(&cores_value, "cores", 1, 1)?, &cores_value, "cores")?;
        if cores % nodes != 0 {
            return Err(Issue::at(
                &self.cores,
                "cores",
                format!(
                    "{cores} cores cannot be spread evenly over {nodes} nodes (one worker per node)"
                ),
            ));
        }
        let max_in_flight = small(
            integer(&self.max_in_flight, "max_in_flight", 1, 1)?,
            &self.max_in_flight,
            "max_in_flight",
        )?;
        let idle_timeout_s = integer(
            &self.idle_timeout_s,
            "idle_timeout_s",
            DEFAULT_IDLE_TIMEOUT_S,
            1,
        )?;
        let stop_margin_s = integer(
            &self.stop_margin_s,
            "stop_margin_s",
            DEFAULT_STOP_MARGIN_S,
            0,
        )?;
        if stop_margin_s as f64 >= time_limit_s {
            let at = self.stop_margin_s.as_ref().map_or_else(
                || Issue::at(&self.time_limit, "time_limit", ""),
                |v| Issue::at(v, "stop_margin_s", ""),
            );
            return Err(Issue {
                message: format!(
                    "the stop margin ({stop_margin_s} s) leaves no time of the time limit \
                     ({time_limit_s} s) to run jobs in"
                ),
                ..at
            });
        }
        let check_every_s = integer(
            &self.check_every_s,
            "check_every_s",
            DEFAULT_CHECK_EVERY_S,
            1,
        )?;
        for arg in &self.sbatch_args {
            let option = arg.get_ref().split('=').next().unwrap_or_default();
            if OWN_OPTIONS.contains(&option) {
                return Err(Issue::at(
                    arg,
                    "sbatch_args",
                    format!(
                        "{option} is set by the allocator (from time_limit, nodes, cores, \
                         partition, account, stop_margin_s, directory)"
                    ),
                ));
            }
        }
        let text = |value: Option<Spanned<String>>, key: &'static str| {
            value
                .map(|v| {
                    if v.get_ref().trim().is_empty() {
                        Err(Issue::at(&v, key, "must not be empty"))
                    } else {
                        Ok(v.into_inner())
                    }
                })
                .transpose()
        };
        let coordinator_url = text(self.coordinator_url, "coordinator_url")?;
        if let Some(url) = &coordinator_url
            && !(url.starts_with("http://") || url.starts_with("https://"))
        {
            return Err(Issue {
                span: 0..0,
                key: Some("coordinator_url"),
                message: format!("{url:?} is not an http:// or https:// URL"),
            });
        }
        let script = match self.script {
            Some(script) => {
                let resolved = absolute(folder, script.get_ref());
                if !resolved.is_file() {
                    return Err(Issue::at(
                        &script,
                        "script",
                        format!("no such file: {}", resolved.display()),
                    ));
                }
                Some(resolved)
            }
            None => None,
        };
        Ok(AllocConfig {
            file: path.to_owned(),
            time_limit: self.time_limit.into_inner(),
            time_limit_s,
            nodes,
            cores,
            max_in_flight,
            idle_timeout_s,
            stop_margin_s,
            partition: text(self.partition, "partition")?,
            account: text(self.account, "account")?,
            sbatch_args: self
                .sbatch_args
                .into_iter()
                .map(Spanned::into_inner)
                .collect(),
            worker_args: self.worker_args,
            coordinator_url,
            directory: absolute(folder, self.directory.as_deref().unwrap_or("allocations")),
            script,
            sweep: self.sweep.map(|s| absolute(folder, &s)),
            check_every_s,
        })
    }
}

/// Seconds of a Slurm duration: `MM`, `MM:SS`, `HH:MM:SS`, `D-HH`, `D-HH:MM` or `D-HH:MM:SS`
/// (sbatch `--time`, squeue `%L`). `UNLIMITED`, `INFINITE` and the like are refused: an allocation
/// needs a time limit to be sized.
pub fn parse_slurm_duration(text: &str) -> Result<f64, String> {
    let bad = || {
        format!(
            "{text:?} is not a Slurm time limit (MM, MM:SS, HH:MM:SS, D-HH, D-HH:MM or D-HH:MM:SS)"
        )
    };
    let number = |s: &str| -> Result<u64, String> {
        if s.is_empty() || !s.bytes().all(|b| b.is_ascii_digit()) {
            return Err(bad());
        }
        s.parse().map_err(|_| bad())
    };
    let text = text.trim();
    let (days, rest) = match text.split_once('-') {
        Some((days, rest)) => (Some(number(days)?), rest),
        None => (None, text),
    };
    let parts = rest
        .split(':')
        .map(number)
        .collect::<Result<Vec<u64>, String>>()?;
    let seconds = match (days, parts.as_slice()) {
        (None, [m]) => m * 60,
        (None, [m, s]) => m * 60 + s,
        (None, [h, m, s]) => h * 3600 + m * 60 + s,
        (Some(d), [h]) => d * 86400 + h * 3600,
        (Some(d), [h, m]) => d * 86400 + h * 3600 + m * 60,
        (Some(d), [h, m, s]) => d * 86400 + h * 3600 + m * 60 + s,
        _ => return Err(bad()),
    };
    if seconds == 0 {
        return Err(format!("{text:?}: a time limit must be positive"));
    }
    Ok(seconds as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<AllocConfig, ConfigError> {
        AllocConfig::parse(text, Path::new("alloc.toml"), Path::new("/shared/run"))
    }

    #[test]
    fn slurm_durations() {
        assert_eq!(parse_slurm_duration("30"), Ok(1800.0));
        assert_eq!(parse_slurm_duration("1:30"), Ok(90.0));
        assert_eq!(parse_slurm_duration("2:00:00"), Ok(7200.0));
        assert_eq!(parse_slurm_duration("1-0"), Ok(86400.0));
        assert_eq!(parse_slurm_duration("1-2:03"), Ok(93780.0));
        assert_eq!(parse_slurm_duration("1-02:03:04"), Ok(93784.0));
        for bad in ["", "UNLIMITED", "1:2:3:4", "-5", "1h", "0", "1-2-3"] {
            assert!(parse_slurm_duration(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn a_minimal_file_takes_the_defaults() {
        let c = parse("time_limit = \"1:00:00\"\ncores = 4\n").unwrap();
        assert_eq!(c.time_limit_s, 3600.0);
        assert_eq!((c.nodes, c.cores, c.max_in_flight), (1, 4, 1));
        assert_eq!(c.idle_timeout_s, DEFAULT_IDLE_TIMEOUT_S);
        assert_eq!(c.usable_s(), 3600.0 - DEFAULT_STOP_MARGIN_S as f64);
        assert_eq!(c.directory, Path::new("/shared/run/allocations"));
        assert_eq!(c.script, None);
    }

    #[test]
    fn every_key() {
        let c = parse(
            r#"
time_limit = "1-00:00:00"
cores = 32
nodes = 2
max_in_flight = 3
idle_timeout_s = 60
stop_margin_s = 300
partition = "compute"
account = "p42"
sbatch_args = ["--qos=long"]
worker_args = ["--lease-batch", "1"]
coordinator_url = "https://login:7070"
directory = "/scratch/allocs"
sweep = "bin/sweep"
check_every_s = 10
"#,
        )
        .unwrap();
        assert_eq!(c.cores_per_node(), 16);
        assert_eq!(c.partition.as_deref(), Some("compute"));
        assert_eq!(c.sweep.as_deref(), Some(Path::new("/shared/run/bin/sweep")));
        assert_eq!(c.directory, Path::new("/scratch/allocs"));
        assert_eq!(c.check_every_s, 10);
    }

    /// Each bad file is refused with its line and key.
    #[test]
    fn bad_files_name_the_line_and_key() {
        let cases: &[(&str, &str)] = &[
            (
                "time_limit = \"1:00:00\"\ncores = 4\npartiton = \"x\"\n",
                "alloc.toml:3:1: unknown field `partiton`",
            ),
            ("cores = 4\n", "missing field `time_limit`"),
            (
                "time_limit = \"soon\"\ncores = 4\n",
                "alloc.toml:1:14: key `time_limit`: \"soon\" is not a Slurm time limit",
            ),
            (
                "time_limit = \"1:00:00\"\ncores = 0\n",
                "alloc.toml:2:9: key `cores`: must be an integer of at least 1, got 0",
            ),
            (
                "time_limit = \"1:00:00\"\ncores = 3\nnodes = 2\n",
                "alloc.toml:2:9: key `cores`: 3 cores cannot be spread evenly over 2 nodes",
            ),
            (
                "time_limit = \"2:00\"\ncores = 1\n",
                "alloc.toml:1:14: key `time_limit`: the stop margin (120 s) leaves no time",
            ),
            (
                "time_limit = \"10:00\"\ncores = 1\nsbatch_args = [\"--time=5\"]\n",
                "alloc.toml:3:16: key `sbatch_args`: --time is set by the allocator",
            ),
            (
                "time_limit = \"10:00\"\ncores = \"four\"\n",
                "alloc.toml:2:9: invalid type: string \"four\", expected i64",
            ),
            (
                "time_limit = \"10:00\"\ncores = 1\nscript = \"nowhere.sbatch\"\n",
                "alloc.toml:3:10: key `script`: no such file: /shared/run/nowhere.sbatch",
            ),
            (
                "time_limit = \"10:00\"\ncores = 1\nmax_in_flight = -1\n",
                "alloc.toml:3:17: key `max_in_flight`: must be an integer of at least 1",
            ),
        ];
        for (text, expected) in cases {
            let error = parse(text).unwrap_err().to_string();
            assert!(
                error.contains(expected),
                "{text:?}:\n  got      {error}\n  expected {expected}"
            );
            assert!(!error.contains('\n'), "one line: {error}");
        }
    }
}
