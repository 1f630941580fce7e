//! A plan file becomes a campaign: read, validated completely, hashed. Shared by local mode and
//! by the coordinator's Submit, so a bad plan gets the same message on both paths.

use std::path::Path;

use anyhow::Context;
use coordinator::{NewCampaign, NewJob};
use jobs::{JobSpec, Plan};

pub struct Campaign {
    pub plan: Plan,
    pub campaign: NewCampaign,
    pub jobs: Vec<NewJob>,
}

/// The job row of a point.
pub fn new_job(spec: &JobSpec, exclusive: bool) -> NewJob {
    NewJob {
        id: spec.id(),
        kind: spec.kind().to_string(),
        params_json: spec.canonical_json(),
        estimate_s: spec.estimate_seconds(),
        exclusive,
        pass: spec.pass(),
        foreign_code: spec.runs_foreign_code(),
    }
}

pub fn read_plan_file(path: &Path) -> anyhow::Result<(String, String)> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    Ok((text, path.display().to_string()))
}

/// Parses and validates `text`; nothing is written anywhere before this succeeds. `dir` is the
/// plan's folder when it is not that of `file_name` (a plan submitted from elsewhere).
pub fn from_plan(
    text: &str,
    file_name: &str,
    dir: Option<&Path>,
) -> Result<Campaign, jobs::PlanError> {
    let plan = match dir {
        Some(dir) => Plan::parse_in(text, file_name, dir)?,
        None => Plan::parse(text, file_name)?,
    };
    let jobs: Vec<NewJob> = plan
        .jobs
        .iter()
        .map(|spec| new_job(spec, plan.exclusive_timing))
        .collect();
    // The campaign is its name and its set of points and searches: the same plan is the same
    // campaign (a search's evaluations join it as it goes).
    let searches: Vec<String> = plan
        .tunes
        .iter()
        .map(|t| format!("tune {} {:?} {:?} {}", t.knob, t.range, t.goal, t.id()))
        .collect();
    let mut ids: Vec<&str> = jobs
        .iter()
        .map(|j| j.id.as_str())
        .chain(searches.iter().map(String::as_str))
        .collect();
    ids.sort_unstable();
    let digest = blake3::hash(format!("{}\n{}", plan.name, ids.join("\n")).as_bytes());
    let campaign = NewCampaign {
        id: digest.to_hex()[..16].to_string(),
        name: plan.name.clone(),
        plan_text: text.to_string(),
        searches: plan
            .tunes
            .iter()
            .map(serde_json::to_string)
            .collect::<Result<_, _>>()
            .expect("a search serialises"),
    };
    Ok(Campaign {
        plan,
        campaign,
        jobs,
    })
}
