//! How the overlap points of a campaign were measured, from their point records' noise checks:
//! what `sweep status` and `sweep run` print under "timing", and what the status page shows.

use serde::{Deserialize, Serialize};
use store::Store;

use crate::error::{Error, Result};

/// How the overlap points of a campaign were measured.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct OverlapQuality {
    /// Points measured with the noise check.
    pub checked: u64,
    /// Points still measured on a disturbed machine after their re-runs (flagged).
    pub disturbed: u64,
    /// Points re-run at least once because the machine was disturbed.
    pub rerun: u64,
    /// Re-runs in all.
    pub reruns: u64,
    /// Wall time of their measurements, re-runs included, and the part in the timed loops.
    pub wall_s: f64,
    pub timed_s: f64,
}

/// [`OverlapQuality`] of one campaign, or of the whole store with `None`. One aggregate in SQL
/// over the point records (the `overlap_measurements` view): the status page asks for it at
/// every sample, and reading every record with its blocks would cost far more.
pub async fn overlap_quality(store: &Store, campaign: Option<&str>) -> Result<OverlapQuality> {
    let result = store
        .query_read_only_with(
            "SELECT count(*), total(m.disturbed), count(*) FILTER (WHERE m.reruns > 0),
                    total(m.reruns), total(m.wall_s), total(m.timed_s)
             FROM overlap_measurements AS m
             WHERE ?1 IS NULL
                OR m.job_id IN (SELECT job_id FROM campaign_jobs WHERE campaign_id = ?1)",
            &[campaign.into()],
        )
        .await?;
    let row = result.rows.first().map(Vec::as_slice).unwrap_or_default();
    let number = |i: usize| {
        row.get(i)
            .and_then(serde_json::Value::as_f64)
            .ok_or_else(|| Error::Totals(format!("the noise checks' total {i} is not a number")))
    };
    let count = |i: usize| number(i).map(|n| n.max(0.0) as u64);
    Ok(OverlapQuality {
        checked: count(0)?,
        disturbed: count(1)?,
        rerun: count(2)?,
        reruns: count(3)?,
        wall_s: number(4)?,
        timed_s: number(5)?,
    })
}
