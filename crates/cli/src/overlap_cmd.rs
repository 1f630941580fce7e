//! `sweep overlap --input CASES.csv`: for every row, each algorithm's verdict where the precision
//! can judge it (`undecided`, with the reason, where it cannot), the exact verdict of Eq. 2 and
//! the distance. A malformed row (not a number, a size not positive, the zero quaternion) refuses
//! the file, naming the row and column.

use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Args;
use std::collections::BTreeMap;

use overlap::config::axes_from_quaternion;
use overlap::judge::{Case, Judgement, judge};
use overlap::{Algorithm, OverlapError, Precision};
use serde::Serialize;

use crate::output::{Format, print_json, print_table, write_csv};

#[derive(Args)]
pub struct OverlapArgs {
    /// CSV with columns rx,ry,rz,radius,half_t,half_l,half_w,qw,qx,qy,qz (any order, a header row).
    #[arg(long)]
    input: PathBuf,
    #[arg(
        long,
        default_value = "f32",
        value_parser = |s: &str| s.parse::<Precision>().map_err(|e: OverlapError| e.to_string())
    )]
    precision: Precision,
}

const COLUMNS: [&str; 11] = [
    "rx", "ry", "rz", "radius", "half_t", "half_l", "half_w", "qw", "qx", "qy", "qz",
];

/// A row's answer: each algorithm's verdict (`0`, `1`, or `undecided` where the precision
/// cannot judge the row), the exact verdict of Eq. 2 and the distance, and why a verdict is
/// missing.
#[derive(Serialize)]
struct Row {
    row: usize,
    #[serde(flatten)]
    verdicts: BTreeMap<&'static str, Verdict>,
    distance: f64,
    exact: Verdict,
    /// Why the precision (or the exact evaluation) could not judge the row; absent when every
    /// verdict is given.
    #[serde(skip_serializing_if = "Option::is_none")]
    undecided: Option<String>,
}

/// `0`, `1`, or the string `undecided`.
#[derive(Clone, Copy)]
enum Verdict {
    Decided(bool),
    Undecided,
}

impl Serialize for Verdict {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        match self {
            Verdict::Decided(v) => serializer.serialize_u8(u8::from(*v)),
            Verdict::Undecided => serializer.serialize_str("undecided"),
        }
    }
}

impl std::fmt::Display for Verdict {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Verdict::Decided(v) => write!(f, "{}", u8::from(*v)),
            Verdict::Undecided => f.write_str("undecided"),
        }
    }
}

pub fn run(args: &OverlapArgs, format: Format) -> anyhow::Result<()> {
    let name = args.input.display().to_string();
    let cases = read_cases(&args.input).with_context(|| name.clone())?;
    let rows: Vec<Row> = cases
        .iter()
        .enumerate()
        .map(|(row, case)| {
            let judgement = match args.precision {
                Precision::F32 => judge::<f32>(case),
                Precision::F64 => judge::<f64>(case),
            };
            answer(row, judgement, args.precision)
        })
        .collect();
    let mut header = vec!["row"];
    header.extend(Algorithm::ALL.map(Algorithm::name));
    header.extend(["distance", "exact", "undecided"]);
    let cells = rows.iter().map(|r| {
        let mut cells = vec![r.row.to_string()];
        cells.extend(Algorithm::ALL.map(|a| r.verdicts[a.name()].to_string()));
        cells.push(format!("{:.9e}", r.distance));
        cells.push(r.exact.to_string());
        cells.push(r.undecided.clone().unwrap_or_default());
        cells
    });
    match format {
        Format::Json => print_json(&rows),
        Format::Csv => write_csv(
            &header.iter().map(|h| h.to_string()).collect::<Vec<_>>(),
            cells,
        ),
        Format::Table => {
            print_table(&header, &cells.collect::<Vec<_>>());
            Ok(())
        }
    }
}

/// A row's answer from its judgement: every kernel undecided where the precision cannot judge
/// the row, the exact verdict undecided where its range stops.
fn answer(row: usize, judgement: Judgement, precision: Precision) -> Row {
    let (verdicts, precision_why) = match judgement.kernels {
        Ok(verdicts) => (
            verdicts
                .into_iter()
                .map(|(a, v)| (a.name(), Verdict::Decided(v)))
                .collect(),
            None,
        ),
        Err(why) => (
            Algorithm::ALL
                .map(|a| (a.name(), Verdict::Undecided))
                .into_iter()
                .collect(),
            Some(format!("{precision}: {why}")),
        ),
    };
    let (exact, exact_why) = match judgement.exact {
        Ok(v) => (Verdict::Decided(v), None),
        Err(why) => (Verdict::Undecided, Some(format!("exact: {why}"))),
    };
    let undecided = match (precision_why, exact_why) {
        (Some(a), Some(b)) => Some(format!("{a}; {b}")),
        (a, b) => a.or(b),
    };
    Row {
        row,
        verdicts,
        distance: judgement.distance,
        exact,
        undecided,
    }
}

/// Reads and validates every row before anything is computed; the first malformed cell is
/// reported with its row (0-based, as in the output) and column.
fn read_cases(path: &std::path::Path) -> anyhow::Result<Vec<Case>> {
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_path(path)?;
    let headers = reader.headers()?.clone();
    let index: Vec<usize> = COLUMNS
        .iter()
        .map(|col| {
            headers
                .iter()
                .position(|h| h == *col)
                .with_context(|| format!("missing column `{col}`"))
        })
        .collect::<anyhow::Result<_>>()?;
    let mut cases = Vec::new();
    for (row, record) in reader.records().enumerate() {
        let record = record.with_context(|| format!("row {row}"))?;
        let mut values = [0.0; 11];
        for (k, (&col, &i)) in COLUMNS.iter().zip(&index).enumerate() {
            let cell = record
                .get(i)
                .with_context(|| format!("row {row}, column `{col}`: missing value"))?;
            let v: f64 = cell
                .parse()
                .with_context(|| format!("row {row}, column `{col}`: `{cell}` is not a number"))?;
            if !v.is_finite() {
                bail!("row {row}, column `{col}`: `{cell}` is not a finite number");
            }
            values[k] = v;
        }
        let [rx, ry, rz, radius, half_t, half_l, half_w, qw, qx, qy, qz] = values;
        for (col, v) in [
            ("radius", radius),
            ("half_t", half_t),
            ("half_l", half_l),
            ("half_w", half_w),
        ] {
            if v <= 0.0 {
                bail!("row {row}, column `{col}`: must be positive, got {v}");
            }
        }
        let norm = (qw * qw + qx * qx + qy * qy + qz * qz).sqrt();
        if norm.is_nan() || norm <= 1e-12 {
            bail!("row {row}, columns `qw,qx,qy,qz`: the zero quaternion is not a rotation");
        }
        let q = [qw, qx, qy, qz].map(|x| x / norm);
        cases.push(Case {
            r_sc: [rx, ry, rz],
            radius,
            half: [half_t, half_l, half_w],
            axes: axes_from_quaternion(q),
        });
    }
    Ok(cases)
}
