//! `sweep overlap --input CASES.csv`: every algorithm's verdict and Eq. 2's distance per row.

use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Args;
use overlap::config::axes_from_quaternion;
use overlap::{
    Algorithm, Configuration, Cuboid, Kernels, OverlapError, Precision, min_distance, overlaps,
};
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

/// One validated row, in f64 as read.
struct Case {
    r_sc: [f64; 3],
    radius: f64,
    half: [f64; 3],
    axes: [[f64; 3]; 3],
}

#[derive(Serialize)]
struct Verdicts {
    row: usize,
    #[serde(flatten)]
    overlaps: std::collections::BTreeMap<&'static str, u8>,
    distance: f64,
}

pub fn run(args: &OverlapArgs, format: Format) -> anyhow::Result<()> {
    let name = args.input.display().to_string();
    let cases = read_cases(&args.input).with_context(|| name.clone())?;
    let verdicts: Vec<Verdicts> = match args.precision {
        Precision::F32 => cases
            .iter()
            .enumerate()
            .map(|(row, c)| evaluate::<f32>(row, c))
            .collect::<anyhow::Result<_>>(),
        Precision::F64 => cases
            .iter()
            .enumerate()
            .map(|(row, c)| evaluate::<f64>(row, c))
            .collect::<anyhow::Result<_>>(),
    }
    .with_context(|| name.clone())?;
    let mut header = vec!["row"];
    header.extend(Algorithm::ALL.map(Algorithm::name));
    header.push("distance");
    let rows = verdicts.iter().map(|v| {
        let mut cells = vec![v.row.to_string()];
        cells.extend(Algorithm::ALL.map(|a| v.overlaps[a.name()].to_string()));
        cells.push(format!("{:.9e}", v.distance));
        cells
    });
    match format {
        Format::Json => print_json(&verdicts),
        Format::Csv => write_csv(
            &header.iter().map(|h| h.to_string()).collect::<Vec<_>>(),
            rows,
        ),
        Format::Table => {
            print_table(&header, &rows.collect::<Vec<_>>());
            Ok(())
        }
    }
}

/// The verdicts of one row in precision `T`, or an error naming the row and column when `T`
/// cannot judge it ([`overlap::range::check_case`]): never a confident wrong verdict.
fn evaluate<T: Kernels>(row: usize, case: &Case) -> anyhow::Result<Verdicts> {
    let exact = min_distance(
        &Configuration {
            r_sc: case.r_sc,
            axes: case.axes,
        },
        &Cuboid { half: case.half },
    );
    let columns = ["rx", "ry", "rz", "radius", "half_t", "half_l", "half_w"];
    overlap::range::check_case::<T>(&case.r_sc, case.radius, &case.half, exact, &columns).map_err(
        |e| match e {
            OverlapError::Invalid { key, reason } => {
                anyhow::anyhow!("row {row}, column `{key}`: {reason}")
            }
        },
    )?;
    let cfg = Configuration {
        r_sc: case.r_sc.map(T::from_f64),
        axes: case.axes.map(|e| e.map(T::from_f64)),
    };
    let cuboid = Cuboid {
        half: case.half.map(T::from_f64),
    };
    let radius = T::from_f64(case.radius);
    Ok(Verdicts {
        row,
        overlaps: Algorithm::ALL
            .into_iter()
            .map(|a| (a.name(), overlaps(a, &cfg, &cuboid, radius) as u8))
            .collect(),
        distance: min_distance(&cfg, &cuboid).to_f64(),
    })
}

/// Reads and validates every row before anything is computed; the first bad cell is reported
/// with its row (0-based, as in the output) and column.
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
