//! Machine history: how a campaign's noise references compare with the earlier campaigns on the
//! same machine. A shift that lasts a whole campaign (a slower host, a neighbour that never
//! left) moves every point alike, so no interval within the campaign can see it; against the
//! machine's earlier campaigns it is at least named.
//!
//! A machine is a worker's host and CPU model. Each overlap point's record carries its compute
//! reference (the core's speed) and its plain read of the arrays (the memory's); a point counts
//! for the first campaign that holds it (later ones find it done). A campaign's reference on a
//! machine is the median over its points of the faster of the point's two readings; reads are
//! compared within a size class of the arrays only (a set in the cache reads faster than one in
//! memory). A campaign is named when its reference is slower than the median of the earlier
//! campaigns' by more than [`COMPUTE_TOLERANCE`] or [`MEMORY_TOLERANCE`]: tighter than a single
//! point's tolerances ([`overlap::noise`]), since a median over a campaign's points is steadier
//! than one point's reading (measured in MEASUREMENTS.md, "Noise check").

use std::collections::BTreeMap;

use serde::Serialize;
use store::Store;

use crate::error::{Error, Result};

/// A campaign's median compute reference may be this many times the earlier campaigns' on its
/// machine: seven quiet campaigns on the development VM spanned ±1.2 %.
pub const COMPUTE_TOLERANCE: f64 = 1.05;
/// A campaign's median plain read of a size class may be this many times the earlier campaigns'
/// on its machine: seven quiet campaigns spanned ±1 % for sets of 9.6 MB and ±13 % for sets of
/// 19 MB (more than half the shared last-level cache); a stream on the other core moved the
/// latter 1.58×.
pub const MEMORY_TOLERANCE: f64 = 1.25;

/// A campaign whose references on one machine moved against that machine's earlier campaigns.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MachineShift {
    pub campaign: String,
    pub campaign_name: String,
    /// The worker's host and CPU model.
    pub machine: String,
    /// `compute` (the core) or `memory` (the plain read of sets of `arrays_bytes`' size class).
    pub reference: &'static str,
    /// For `memory`: the size class, as the smallest set of it, in bytes.
    pub arrays_bytes: Option<u64>,
    /// This campaign's reference over the earlier campaigns' median: above 1 is slower.
    pub ratio: f64,
    pub earlier_campaigns: usize,
    /// The sentence a report prints.
    pub message: String,
}

/// One point's readings, with the campaign and machine it belongs to.
struct Reading {
    campaign: String,
    campaign_name: String,
    created_at: f64,
    machine: String,
    compute_ns: Option<f64>,
    stream: Option<(u32, f64)>,
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n % 2 == 1 {
        values[n / 2]
    } else {
        (values[n / 2 - 1] + values[n / 2]) / 2.0
    }
}

/// The faster of two readings, where there is one.
fn faster(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
    .filter(|x| x.is_finite() && *x > 0.0)
}

async fn readings(store: &Store) -> Result<Vec<Reading>> {
    let rows = store
        .query_read_only(
            "SELECT c.id, c.name, c.created_at, w.hostname || ' (' || w.cpu_model || ')',
                    m.reference_compute_ns_before, m.reference_compute_ns_after, m.arrays_bytes,
                    m.reference_stream_ns_before, m.reference_stream_ns_after
             FROM overlap_measurements AS m
             JOIN workers AS w ON w.id = m.worker_id
             JOIN campaigns AS c ON c.id = (
                 SELECT cj.campaign_id FROM campaign_jobs AS cj
                 JOIN campaigns AS first ON first.id = cj.campaign_id
                 WHERE cj.job_id = m.job_id ORDER BY first.created_at, first.id LIMIT 1)",
        )
        .await?;
    let bad = |what: &str| Error::Totals(format!("machine history: {what}"));
    rows.rows
        .iter()
        .map(|row| {
            let text = |i: usize| {
                row[i]
                    .as_str()
                    .map(str::to_owned)
                    .ok_or_else(|| bad("a campaign or worker without its name"))
            };
            let number = |i: usize| row[i].as_f64();
            let stream = faster(number(7), number(8));
            let bytes = row[6].as_u64().filter(|&b| b > 0);
            Ok(Reading {
                campaign: text(0)?,
                campaign_name: text(1)?,
                created_at: number(2).ok_or_else(|| bad("a campaign without its time"))?,
                machine: text(3)?,
                compute_ns: faster(number(4), number(5)),
                stream: bytes.zip(stream).map(|(b, s)| (b.ilog2(), s)),
            })
        })
        .collect()
}

/// Every campaign whose compute reference, or read of some size class, was slower on some
/// machine than that machine's earlier campaigns beyond the noise check's tolerance, in the
/// order the campaigns were made.
pub async fn machine_history(store: &Store) -> Result<Vec<MachineShift>> {
    // (machine, reference, size class) → campaigns in time order → their readings.
    type Series =
        BTreeMap<(String, &'static str, Option<u32>), Vec<(f64, String, String, Vec<f64>)>>;
    let mut series: Series = BTreeMap::new();
    let mut add = |key: (String, &'static str, Option<u32>), reading: &Reading, value: f64| {
        let campaigns = series.entry(key).or_default();
        match campaigns.iter_mut().find(|c| c.1 == reading.campaign) {
            Some(campaign) => campaign.3.push(value),
            None => campaigns.push((
                reading.created_at,
                reading.campaign.clone(),
                reading.campaign_name.clone(),
                vec![value],
            )),
        }
    };
    for reading in readings(store).await? {
        if let Some(compute) = reading.compute_ns {
            add(
                (reading.machine.clone(), "compute", None),
                &reading,
                compute,
            );
        }
        if let Some((class, stream)) = reading.stream {
            add(
                (reading.machine.clone(), "memory", Some(class)),
                &reading,
                stream,
            );
        }
    }
    let mut shifts = Vec::new();
    for ((machine, reference, class), mut campaigns) in series {
        campaigns.sort_by(|a, b| a.0.total_cmp(&b.0).then_with(|| a.1.cmp(&b.1)));
        let tolerance = match reference {
            "compute" => COMPUTE_TOLERANCE,
            _ => MEMORY_TOLERANCE,
        };
        let mut earlier: Vec<f64> = Vec::new();
        for (created_at, campaign, name, mut values) in campaigns {
            let this = median(&mut values);
            if !earlier.is_empty() {
                let ratio = this / median(&mut earlier.clone());
                if ratio > tolerance {
                    let what = match class {
                        None => "its compute reference".to_owned(),
                        Some(class) => format!(
                            "its plain read of sets of {}–{} MiB",
                            (1u64 << class) >> 20,
                            (2u64 << class) >> 20
                        ),
                    };
                    shifts.push((
                        created_at,
                        MachineShift {
                            message: format!(
                                "campaign {name} ({campaign}) ran {ratio:.2}× slower by {what} than the {} earlier campaign(s) on {machine} (tolerance {tolerance:.2}×): a change of the machine that lasted the campaign, which no interval within it can show",
                                earlier.len()
                            ),
                            campaign,
                            campaign_name: name,
                            machine: machine.clone(),
                            reference,
                            arrays_bytes: class.map(|c| 1u64 << c),
                            ratio,
                            earlier_campaigns: earlier.len(),
                        },
                    ));
                }
            }
            earlier.push(this);
        }
    }
    shifts.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(shifts.into_iter().map(|(_, shift)| shift).collect())
}
