//! The machine and build a result was measured on: stored with every result row.

use queue::WorkerInfo;

/// CPU features that change what the kernels run (`ocsi_batch` dispatches on them).
const RELEVANT_FLAGS: [&str; 6] = ["sse2", "avx", "avx2", "fma", "avx512f", "avx512vl"];

fn cpuinfo_field(cpuinfo: &str, key: &str) -> Option<String> {
    cpuinfo
        .lines()
        .find(|l| l.split(':').next().is_some_and(|k| k.trim() == key))
        .and_then(|l| l.split_once(':'))
        .map(|(_, v)| v.trim().to_string())
}

pub fn hostname() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|s| s.trim().to_string())
        .ok()
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown-host".into())
}

/// Provenance of this process, for a worker named `id` with core budget `cores`.
pub fn worker_info(id: String, cores: &[usize]) -> WorkerInfo {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let flags = cpuinfo_field(&cpuinfo, "flags").unwrap_or_default();
    let present: Vec<&str> = RELEVANT_FLAGS
        .into_iter()
        .filter(|f| flags.split_whitespace().any(|g| g == *f))
        .collect();
    WorkerInfo {
        id,
        hostname: hostname(),
        cores: cores.iter().map(|&c| c as u32).collect(),
        cpu_model: cpuinfo_field(&cpuinfo, "model name")
            .unwrap_or_else(|| std::env::consts::ARCH.into()),
        cpu_flags: present.join(" "),
        rustc: env!("SWEEP_RUSTC").into(),
        git_commit: env!("SWEEP_GIT_COMMIT").into(),
        profile: if cfg!(debug_assertions) {
            "debug"
        } else {
            "release"
        }
        .into(),
        allocation: None,
        allow_commands: false,
    }
}
