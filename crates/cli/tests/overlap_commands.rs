//! `sweep bench overlap` and `sweep overlap` as a user runs them: the real binary, real files.

use std::process::{Command, Output};

fn sweep(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sweep"))
        .args(args)
        .output()
        .expect("the sweep binary runs")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

const POINT: [&str; 12] = [
    "bench",
    "overlap",
    "--l-star",
    "4",
    "--w-star",
    "8",
    "--r-star",
    "5",
    "--configurations",
    "200000",
    "--repeats",
    "2",
];

#[test]
fn bench_overlap_reports_every_algorithm_at_the_target_acceptance() {
    let mut args = POINT.to_vec();
    args.extend(["--acceptance", "0.4", "--format", "json"]);
    let out = sweep(&args);
    assert!(out.status.success(), "{}", stderr(&out));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    let results = report["results"].as_array().expect("results");
    let names: Vec<&str> = results
        .iter()
        .map(|r| r["algorithm"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["arvo", "qri", "qrf", "sse", "ocsi", "ocsi_batch"]);
    for r in results {
        // σ of the measured acceptance over 2 × 200,000 configurations is < 10⁻³.
        let acceptance = r["acceptance"].as_f64().unwrap();
        assert!((acceptance - 0.4).abs() < 0.005, "{r}");
        assert!(
            r["mean_ms"].as_f64().unwrap() > 0.0 && r["ns_per_check"].as_f64().unwrap() > 0.0,
            "{r}"
        );
    }
    assert!(report["stream_ns_per_config"].as_f64().unwrap() > 0.0);
}

#[test]
fn bench_overlap_rejects_bad_flags_naming_them() {
    for (flag, value) in [
        ("--l-star", "0"),
        ("--w-star", "-2"),
        ("--r-star", "NaN"),
        ("--acceptance", "0"),
        ("--acceptance", "1"),
        ("--acceptance", "1.5"),
        ("--configurations", "0"),
        ("--repeats", "0"),
        ("--precision", "f16"),
        ("--algorithms", "ocsi,fast"),
    ] {
        let mut args = POINT.to_vec();
        args.extend([flag, value]);
        let out = sweep(&args);
        let err = stderr(&out);
        assert!(!out.status.success(), "{flag} {value} was accepted");
        assert!(
            err.contains(flag),
            "{flag} {value}: the message does not name the flag: {err}"
        );
        assert_eq!(
            err.trim_end().lines().count(),
            1,
            "{flag} {value}: not one line: {err}"
        );
        assert!(
            out.stdout.is_empty(),
            "{flag} {value}: printed results anyway"
        );
    }
}

const HEADER: &str = "rx,ry,rz,radius,half_t,half_l,half_w,qw,qx,qy,qz";

fn overlap_csv(body: &str, extra: &[&str]) -> Output {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cases.csv");
    std::fs::write(&path, body).unwrap();
    let mut args = vec!["overlap", "--input", path.to_str().unwrap()];
    args.extend(extra);
    sweep(&args)
}

/// Hand-made cases with known answers, in both precisions: the identity frame, a cuboid turned
/// 90° about z (ê_T = ŷ), and a corner at distance √3; every row with the exact verdict.
#[test]
fn overlap_gives_every_verdict_the_exact_one_and_the_distance() {
    let body = format!(
        "{HEADER}\n\
         2.5,0,0,1,0.5,1,1,1,0,0,0\n\
         2.5,0,0,2.5,0.5,1,1,1,0,0,0\n\
         0.1,0.2,0.3,0.01,0.5,1,1,1,0,0,0\n\
         0,2.5,0,1.9,0.5,1,1,0.7071067811865476,0,0,0.7071067811865476\n\
         2,2,2,1.8,1,1,1,2,0,0,0\n"
    );
    for precision in ["f32", "f64"] {
        let out = overlap_csv(&body, &["--precision", precision, "--format", "json"]);
        assert!(out.status.success(), "{}", stderr(&out));
        let rows: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
        let expected = [(0, 2.0), (1, 2.0), (1, 0.0), (0, 2.0), (1, 3f64.sqrt())];
        assert_eq!(rows.len(), expected.len());
        for (row, (hit, distance)) in rows.iter().zip(expected) {
            for algorithm in ["arvo", "qri", "qrf", "sse", "ocsi", "ocsi_batch"] {
                assert_eq!(row[algorithm], hit, "{precision} {algorithm} {row}");
            }
            assert_eq!(row["exact"], hit, "{precision} {row}");
            assert!(row.get("undecided").is_none(), "{row}");
            assert!(
                (row["distance"].as_f64().unwrap() - distance).abs() < 1e-12,
                "{precision} {row}"
            );
        }
    }
}

/// A file of 2,000 rows with one that a precision cannot judge still gets every answer: that
/// row says `undecided` with the reason, in its kernels' columns only, and keeps its exact
/// verdict; rows beyond a precision's range are answered the same way.
#[test]
fn overlap_answers_every_row_and_says_which_it_cannot_judge() {
    let decided = "2.5,0,0,1,0.5,1,1,1,0,0,0\n".repeat(1999);
    let body = format!(
        "{HEADER}\n1.5,0,0,1,0.5,1,1,1,0,0,0\n{decided}1e39,0,0,1,0.5,1,1,1,0,0,0\n3,0,0,1e-40,0.5,1,1,1,0,0,0\n"
    );
    let out = overlap_csv(&body, &["--format", "json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let rows: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(rows.len(), 2002);
    let touching = &rows[0];
    assert_eq!(touching["qri"], "undecided");
    assert_eq!(touching["exact"], 1, "touching counts as overlapping");
    let why = touching["undecided"].as_str().unwrap();
    assert!(
        why.starts_with("f32: radius: the sphere is within rounding of touching"),
        "{why}"
    );
    assert!(
        rows[1..2000]
            .iter()
            .all(|r| r["ocsi"] == 0 && r["exact"] == 0)
    );
    // Beyond f32's range, and so far from the cuboid that Eq. 2 is decided without exact
    // arithmetic.
    let far = &rows[2000];
    assert_eq!(
        (&far["arvo"], &far["exact"]),
        (&serde_json::json!("undecided"), &serde_json::json!(0))
    );
    let why = far["undecided"].as_str().unwrap();
    assert!(
        why.starts_with("f32: rx:") && why.contains("beyond what f32 can square"),
        "{why}"
    );
    let tiny = &rows[2001];
    assert_eq!(tiny["sse"], "undecided");
    assert!(
        tiny["undecided"]
            .as_str()
            .unwrap()
            .starts_with("f32: radius:"),
        "{tiny}"
    );
    // f64 judges the row f32 cannot.
    let out = overlap_csv(&body, &["--format", "json", "--precision", "f64"]);
    let rows: Vec<serde_json::Value> = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(rows[2001]["sse"], 0, "{}", rows[2001]);
    assert_eq!(
        rows[0]["qrf"], "undecided",
        "touching stays undecided in f64"
    );
    // The CSV has the same columns as the contract, the reason last.
    let out = overlap_csv(&body, &["--format", "csv"]);
    let text = String::from_utf8(out.stdout).unwrap();
    assert_eq!(
        text.lines().next().unwrap(),
        "row,arvo,qri,qrf,sse,ocsi,ocsi_batch,distance,exact,undecided"
    );
}

#[test]
fn overlap_rejects_malformed_rows_naming_row_and_column() {
    let good = "1,0,0,1,0.5,1,1,1,0,0,0";
    for (body, needle) in [
        (
            "rx,ry,rz,radius,half_t,half_l,half_w,qw,qx,qy\n1,0,0,1,0.5,1,1,1,0,0\n".to_string(),
            "missing column `qz`",
        ),
        (
            format!("{HEADER}\n{good}\n1,0,0,NaN,0.5,1,1,1,0,0,0\n"),
            "row 1, column `radius`",
        ),
        (
            format!("{HEADER}\n1,0,0,1,0,1,1,1,0,0,0\n"),
            "row 0, column `half_t`",
        ),
        (
            format!("{HEADER}\n1,0,0,1,0.5,-1,1,1,0,0,0\n"),
            "row 0, column `half_l`",
        ),
        (
            format!("{HEADER}\n1,0,0,-1,0.5,1,1,1,0,0,0\n"),
            "row 0, column `radius`",
        ),
        (
            format!("{HEADER}\n{good}\n{good}\n1,0,0,1,0.5,1,1,0,0,0,0\n"),
            "row 2, columns `qw,qx,qy,qz`",
        ),
        (
            format!("{HEADER}\n1,zero,0,1,0.5,1,1,1,0,0,0\n"),
            "row 0, column `ry`",
        ),
        (format!("{HEADER}\n1,0,0,1,0.5,1,1,1,0,0\n"), "row 0"),
    ] {
        let out = overlap_csv(&body, &[]);
        let err = stderr(&out);
        assert!(!out.status.success(), "accepted: {body}");
        assert!(err.contains(needle), "expected `{needle}` in: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "not one line: {err}");
        assert!(out.stdout.is_empty(), "printed verdicts despite a bad row");
    }
}

#[test]
fn overlap_names_a_missing_file() {
    let out = sweep(&["overlap", "--input", "/nonexistent/cases.csv"]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("/nonexistent/cases.csv"));
}
