//! What the binary needs from the operating system: logs, core pinning, memory figures.

use anyhow::{Context, bail};
use tracing_subscriber::EnvFilter;

/// Logs to stderr, filtered by `RUST_LOG` (default: warnings).
pub fn init_logging() {
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new("warn"));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .init();
}

/// Starts rayon's global pool before any thread is pinned: threads inherit the affinity of the
/// thread that spawns them, and the untimed generation must keep every core.
pub fn start_thread_pool() -> anyhow::Result<()> {
    rayon::ThreadPoolBuilder::new()
        .build_global()
        .or_else(|e| {
            // Already started (e.g. by an earlier call): fine, it was started unpinned.
            tracing::debug!("rayon pool: {e}");
            Ok::<_, anyhow::Error>(())
        })?;
    rayon::broadcast(|_| ());
    Ok(())
}

/// Pins the calling thread to core `core` (an id of `core_affinity::get_core_ids`).
pub fn pin_current_thread(core: usize) -> anyhow::Result<()> {
    let ids = core_affinity::get_core_ids().context("cannot list this machine's cores")?;
    let Some(id) = ids.into_iter().find(|id| id.id == core) else {
        bail!("--core {core}: no such core available to this process");
    };
    if !core_affinity::set_for_current(id) {
        bail!("--core {core}: the operating system refused to pin the thread");
    }
    Ok(())
}

/// Peak resident memory of this process (`VmHWM`), where the OS reports it.
pub fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Every core this process may run on.
pub fn available_cores() -> anyhow::Result<Vec<usize>> {
    let ids = core_affinity::get_core_ids().context("cannot list this machine's cores")?;
    Ok(ids.into_iter().map(|c| c.id).collect())
}

/// A `--cores` value. A newtype, because clap reads `Option<Vec<_>>` as "several values".
#[derive(Clone, Debug)]
pub struct CoreList(pub Vec<usize>);

/// The cores to use: the list given, or every core available to this process.
pub fn cores_or_all(list: &Option<CoreList>) -> anyhow::Result<Vec<usize>> {
    match list {
        Some(CoreList(cores)) => Ok(cores.clone()),
        None => available_cores(),
    }
}

/// The first `count` of the `available` cores (this process's affinity mask, ascending): how a
/// worker uses a count its scheduler gives (`SLURM_CPUS_ON_NODE`, a Kubernetes CPU limit through
/// the downward API) when the mask alone may be wider than the allocation. More than are available
/// is an error, not a silent oversubscription of the cores that timings run on.
pub fn first_cores(available: &[usize], count: usize) -> anyhow::Result<Vec<usize>> {
    if count > available.len() {
        let list = available
            .iter()
            .map(usize::to_string)
            .collect::<Vec<_>>()
            .join(",");
        bail!(
            "--core-count {count}: only {} cores are available to this process ({list})",
            available.len()
        );
    }
    Ok(available[..count].to_vec())
}

/// `0,2-3` → [0, 2, 3]: core lists as `taskset` and Slurm write them.
pub fn parse_core_list(s: &str) -> Result<CoreList, String> {
    let mut cores = Vec::new();
    for part in s.split(',').map(str::trim) {
        let number = |x: &str| {
            x.trim()
                .parse::<usize>()
                .map_err(|_| format!("`{x}` is not a core number"))
        };
        match part.split_once('-') {
            Some((a, b)) => {
                let (a, b) = (number(a)?, number(b)?);
                if a > b {
                    return Err(format!("`{part}`: the range runs backwards"));
                }
                cores.extend(a..=b);
            }
            None => cores.push(number(part)?),
        }
    }
    cores.sort_unstable();
    cores.dedup();
    if cores.is_empty() {
        return Err("no cores given".into());
    }
    Ok(CoreList(cores))
}

/// Whether process `pid` exists on this machine (Linux: its `/proc` entry).
pub fn process_alive(pid: u32) -> bool {
    std::path::Path::new(&format!("/proc/{pid}")).exists()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_core_count_takes_the_first_cores_of_the_mask() {
        assert_eq!(first_cores(&[2, 3, 6, 7], 2).unwrap(), vec![2, 3]);
        assert_eq!(first_cores(&[2, 3, 6, 7], 4).unwrap(), vec![2, 3, 6, 7]);
    }

    #[test]
    fn a_core_count_beyond_the_mask_is_refused_naming_the_flag_and_the_cores() {
        let message = first_cores(&[4, 5], 3).unwrap_err().to_string();
        assert_eq!(
            message,
            "--core-count 3: only 2 cores are available to this process (4,5)"
        );
    }
}
