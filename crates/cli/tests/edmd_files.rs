//! `sweep edmd` with state files, trajectories and snapshots, as a user runs it: the real
//! binary, real files.

use std::path::Path;
use std::process::{Command, Output};

fn sweep(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sweep"))
        .args(args)
        .output()
        .expect("the sweep binary runs")
}

fn ok(out: Output) -> Output {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn scene(dir: &Path, name: &str, collisions: u64, extra: &str) -> String {
    let path = dir.join(name);
    std::fs::write(
        &path,
        format!(
            "shape = \"ellipsoid\"\nn = 128\nphi = 0.35\nx0 = 2.0\nequilibrate = 0\ncollisions = {collisions}\n{extra}"
        ),
    )
    .unwrap();
    path.display().to_string()
}

#[test]
fn a_saved_state_continues_bit_for_bit_and_draws() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).display().to_string();
    let first = scene(dir.path(), "first.toml", 3_000, "");
    ok(sweep(&[
        "edmd",
        &first,
        "--save-state",
        &p("s.state"),
        "--checkpoint-every",
        "1000",
        "--format",
        "json",
    ]));
    assert!(!dir.path().join("s.state.tmp").exists());
    let whole = scene(dir.path(), "whole.toml", 6_000, "");
    let rest = scene(dir.path(), "rest.toml", 3_000, "from_state = \"s.state\"\n");
    ok(sweep(&[
        "edmd",
        &whole,
        "--dump",
        &p("whole.json"),
        "--format",
        "json",
    ]));
    ok(sweep(&[
        "edmd",
        &rest,
        "--dump",
        &p("rest.json"),
        "--format",
        "json",
    ]));
    // The dump prints every f64 exactly: the same bytes are the same bits.
    assert_eq!(
        std::fs::read(p("whole.json")).unwrap(),
        std::fs::read(p("rest.json")).unwrap()
    );
    // Another system: refused, naming the file and the key; nothing written.
    let other = scene(
        dir.path(),
        "other.toml",
        3_000,
        "from_state = \"s.state\"\n",
    );
    std::fs::write(
        &other,
        std::fs::read_to_string(&other)
            .unwrap()
            .replace("n = 128", "n = 100"),
    )
    .unwrap();
    let out = sweep(&["edmd", &other, "--dump", &p("other.json")]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("s.state") && err.contains("`n`"), "{err}");
    assert!(!dir.path().join("other.json").exists());
    // A picture of the state.
    let out = ok(sweep(&[
        "report",
        "snapshot",
        "--state",
        &p("s.state"),
        "--out",
        &p("snap.png"),
    ]));
    let png = std::fs::read(p("snap.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    assert!(String::from_utf8_lossy(&out.stderr).contains("of 128 bodies"));
    let out = sweep(&["report", "snapshot", "--out", &p("x.png")]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("--state"));
}

/// The last frame a GSD file's index lists (GSD 2: the index's offset at byte 8, entries of
/// 32 bytes, frame first, an unused entry of size 0).
fn last_frame(path: &str) -> u64 {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..8], &0x65DF_65DF_65DF_65DFu64.to_le_bytes());
    let index_at = u64::from_le_bytes(bytes[8..16].try_into().unwrap()) as usize;
    let mut last = 0;
    for e in bytes[index_at..].chunks(32) {
        if u64::from_le_bytes(e[16..24].try_into().unwrap()) == 0 {
            break;
        }
        last = u64::from_le_bytes(e[0..8].try_into().unwrap());
    }
    last
}

#[test]
fn a_trajectory_has_a_frame_every_k_collisions() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).display().to_string();
    let s = scene(dir.path(), "t.toml", 2_000, "");
    ok(sweep(&[
        "edmd",
        &s,
        "--trajectory",
        &p("t.gsd"),
        "--every",
        "500",
        "--format",
        "json",
    ]));
    // The index: frames 0..=4 (the start, then every 500 collisions of 2000).
    assert_eq!(last_frame(&p("t.gsd")), 4);
    let out = sweep(&["edmd", &s, "--every", "5"]);
    assert!(!out.status.success(), "--every needs --trajectory");
    for bad in ["0", "0t", "xt", "1.5", "-1t"] {
        let every = format!("--every={bad}");
        let out = sweep(&["edmd", &s, "--trajectory", &p("b.gsd"), &every]);
        assert!(
            !out.status.success() && String::from_utf8_lossy(&out.stderr).contains("--every"),
            "--every {bad}"
        );
    }
}

#[test]
fn a_trajectory_can_have_a_frame_every_time_interval() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).display().to_string();
    let s = scene(dir.path(), "t.toml", 2_000, "");
    let report = ok(sweep(&[
        "edmd",
        &s,
        "--trajectory",
        &p("t.gsd"),
        "--every",
        "0.01t",
        "--format",
        "json",
    ]));
    let report: serde_json::Value = serde_json::from_slice(&report.stdout).unwrap();
    let last_frame = last_frame(&p("t.gsd"));
    // The start, then one frame per 0.01 of the time the run simulated (equilibration
    // included, which the report's sim_time leaves out: at least as many).
    let sim_time = report["sim_time"].as_f64().unwrap();
    assert!(
        last_frame as f64 >= (sim_time / 0.01).floor(),
        "{last_frame} frames, {sim_time}"
    );
}
