//! Records the compiler and the commit this worker was built from: every result row carries them.
//!
//! The commit is read from the repository's files (HEAD, then the branch's ref, loose or packed),
//! and only those files and the sources are watched: `git status` rewrites `.git/index`, so
//! watching the index made every build rerun this script and recompile the worker and the CLI.
//!
//! "-dirty" means: when this script last ran, a tracked file differed from HEAD
//! (`git status --untracked-files=no`). The script reruns whenever HEAD, the branch's ref or any
//! file under the watched source trees changes, so the flag is current for everything compiled
//! into the binary; an edit to a file outside them (docs, deploy recipes) after the build does not
//! change the binary and does not rerun it.

use std::path::{Path, PathBuf};
use std::process::Command;

/// What the binary is made of, relative to the workspace root.
const SOURCES: [&str; 5] = ["crates", "proto", "migrations", "Cargo.toml", "Cargo.lock"];

fn output(cmd: &str, args: &[&str]) -> Option<String> {
    let out = Command::new(cmd).args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

/// The repository's git directory and its common directory (they differ in a linked worktree,
/// whose `.git` is a file naming its git directory; refs live in the common one).
fn git_dirs(root: &Path) -> Option<(PathBuf, PathBuf)> {
    let dot_git = root.join(".git");
    let git_dir = if dot_git.is_dir() {
        dot_git
    } else {
        let text = std::fs::read_to_string(&dot_git).ok()?;
        root.join(text.strip_prefix("gitdir:")?.trim())
    };
    let common = match std::fs::read_to_string(git_dir.join("commondir")) {
        Ok(relative) => git_dir.join(relative.trim()),
        Err(_) => git_dir.clone(),
    };
    Some((git_dir, common))
}

/// The commit HEAD names, and the files whose change would change it (to be watched).
fn head_commit(git_dir: &Path, common: &Path) -> (Option<String>, Vec<PathBuf>) {
    let head_file = git_dir.join("HEAD");
    let mut watched = vec![head_file.clone()];
    let Ok(head) = std::fs::read_to_string(&head_file) else {
        return (None, watched);
    };
    let Some(reference) = head.trim().strip_prefix("ref:").map(str::trim) else {
        return (Some(head.trim().to_string()), watched); // detached HEAD
    };
    let loose = common.join(reference);
    if let Ok(commit) = std::fs::read_to_string(&loose) {
        watched.push(loose);
        return (Some(commit.trim().to_string()), watched);
    }
    // A packed ref; a commit would write it loose, so watch where it would appear too.
    let packed = common.join("packed-refs");
    watched.push(packed.clone());
    if let Some(parent) = loose.ancestors().skip(1).find(|p| p.is_dir()) {
        watched.push(parent.to_path_buf());
    }
    let commit = std::fs::read_to_string(packed).ok().and_then(|text| {
        text.lines()
            .filter_map(|line| line.split_once(' '))
            .find(|(_, name)| *name == reference)
            .map(|(commit, _)| commit.to_string())
    });
    (commit, watched)
}

fn main() {
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let version = output(&rustc, &["--version"]).unwrap_or_else(|| "unknown".into());
    println!("cargo:rustc-env=SWEEP_RUSTC={version}");

    let root =
        PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"))
            .join("../..");
    let (commit, watched) = match git_dirs(&root) {
        Some((git_dir, common)) => head_commit(&git_dir, &common),
        None => (None, Vec::new()),
    };
    let commit = commit.map_or_else(|| "unknown".to_string(), |c| c.chars().take(12).collect());
    let dirty = commit != "unknown"
        && output("git", &["status", "--porcelain", "--untracked-files=no"])
            .is_some_and(|s| !s.is_empty());
    println!(
        "cargo:rustc-env=SWEEP_GIT_COMMIT={commit}{}",
        if dirty { "-dirty" } else { "" }
    );
    // Only paths that exist: cargo reruns the script on every build for a missing one.
    let sources = SOURCES.iter().map(|source| root.join(source));
    for path in watched
        .into_iter()
        .chain(sources)
        .filter(|path| path.exists())
    {
        println!("cargo:rerun-if-changed={}", path.display());
    }
}
