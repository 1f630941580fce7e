//! `sweep report tune`: every search of every campaign's plan, where it stands.

use jobs::{TuneGoal, TuneSearch};
use serde::Serialize;
use store::Store;

use crate::drive::{DriveError, SearchStep, steps, tau_c_field};
use crate::{Conclusion, Evaluation, Outcome, Step};

/// One search as reported.
#[derive(Clone, Debug, Serialize)]
pub struct SearchRow {
    pub campaign: String,
    pub shape: String,
    pub n: usize,
    pub phi: f64,
    pub x0: f64,
    pub knob: String,
    pub goal: TuneGoal,
    pub range: [f64; 2],
    /// `None` while the search runs.
    pub conclusion: Option<Conclusion>,
    pub evaluations: usize,
    pub max_evaluations: u64,
    /// Every evaluation done, in the order of the knob's value (the search's path).
    pub path: Vec<PathPoint>,
}

#[derive(Clone, Debug, Serialize)]
pub struct PathPoint {
    pub x: f64,
    pub repeat: u32,
    /// The minimised field, or whether the run was safe; `None`: the run failed for good.
    pub value: Option<f64>,
    pub safe: Option<bool>,
}

/// A stored search this version cannot read.
#[derive(Clone, Debug, Serialize)]
pub struct Unreadable {
    pub campaign: String,
    pub reason: String,
}

/// The searches of every campaign of the database (a search in several campaigns once), and
/// those this version cannot read.
pub async fn searches(
    store: &Store,
) -> Result<(Vec<(String, TuneSearch)>, Vec<Unreadable>), DriveError> {
    let (mut found, mut unreadable): (Vec<(String, TuneSearch)>, Vec<Unreadable>) =
        Default::default();
    for s in store.searches().await.map_err(results::Error::from)? {
        match serde_json::from_str::<TuneSearch>(&s.search) {
            Ok(search) => {
                if !found.iter().any(|(_, f)| *f == search) {
                    found.push((s.campaign_name, search));
                }
            }
            Err(e) => unreadable.push(Unreadable {
                campaign: s.campaign_name,
                reason: e.to_string(),
            }),
        }
    }
    Ok((found, unreadable))
}

/// Every search's row.
pub async fn rows(store: &Store) -> Result<(Vec<SearchRow>, Vec<Unreadable>), DriveError> {
    let (found, unreadable) = searches(store).await?;
    let list: Vec<TuneSearch> = found.iter().map(|(_, s)| s.clone()).collect();
    let steps = steps(store, &list).await?;
    let rows = found
        .into_iter()
        .zip(steps)
        .map(|((campaign, search), step)| row(campaign, search, step))
        .collect();
    Ok((rows, unreadable))
}

fn row(campaign: String, search: TuneSearch, step: SearchStep) -> SearchRow {
    let mut path: Vec<PathPoint> = step.done.iter().map(path_point).collect();
    path.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.repeat.cmp(&b.repeat)));
    let t = &search.template;
    SearchRow {
        campaign,
        shape: format!("{:?}", t.shape).to_lowercase(),
        n: t.n,
        phi: t.phi,
        x0: t.x0,
        knob: search.knob.clone(),
        goal: search.goal.clone(),
        range: search.range,
        conclusion: match step.step {
            Step::Done(c) => Some(c),
            _ => None,
        },
        evaluations: step.done.len(),
        max_evaluations: search.max_evaluations,
        path,
    }
}

fn path_point(e: &Evaluation) -> PathPoint {
    let (value, safe) = match e.outcome {
        Outcome::Value(v) => (Some(v), None),
        Outcome::Safe(s) => (None, Some(s)),
        Outcome::Failed => (None, None),
    };
    PathPoint {
        x: e.x,
        repeat: e.repeat,
        value,
        safe,
    }
}

/// The rows as a Markdown table.
pub fn table(rows: &[SearchRow]) -> String {
    let mut out = String::from(
        "| shape | N | φ | X0 | knob | goal | value found | interval | objective there | runs | stopped |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let goal = match &r.goal {
            TuneGoal::Min(field) => format!("min {field}"),
            TuneGoal::LoosestSafe => "loosest safe".to_owned(),
        };
        let (best, interval, objective, stopped) = match &r.conclusion {
            Some(c) => (
                c.best.map_or("–".to_owned(), significant),
                c.interval.map_or("–".to_owned(), |[a, b]| {
                    format!("[{}, {}]", significant(a), significant(b))
                }),
                c.objective.map_or("–".to_owned(), |o| {
                    format!(
                        "{} ± {} at {} ({} runs)",
                        significant(o.mean),
                        significant(o.half_width),
                        significant(o.x),
                        o.runs
                    )
                }),
                c.stopped.as_str().to_owned(),
            ),
            None => ("–".into(), "–".into(), "–".into(), "running".into()),
        };
        out.push_str(&format!(
            "| {} | {} | {} | {} | {} | {goal} | {best} | {interval} | {objective} | {}/{} | {stopped} |\n",
            r.shape, r.n, r.phi, r.x0, r.knob, r.evaluations, r.max_evaluations
        ));
    }
    out
}

/// Four significant digits: the knobs span many decades (ε_d 1e-7, Δ_NNL 0.3, τ_c 20 µs).
fn significant(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let magnitude = x.abs().log10().floor();
    if (-2.0..4.0).contains(&magnitude) {
        format!("{x:.*}", (3.0 - magnitude) as usize)
    } else {
        format!("{x:.3e}")
    }
}

/// The rows as the figure of their paths draws them.
pub fn paths(rows: &[SearchRow]) -> Vec<report::SearchPath> {
    rows.iter()
        .map(|r| report::SearchPath {
            title: format!("{} N = {}, φ = {}, X0 = {}", r.shape, r.n, r.phi, r.x0),
            knob: r.knob.clone(),
            objective: match &r.goal {
                TuneGoal::Min(field) => Some(field.clone()),
                TuneGoal::LoosestSafe => None,
            },
            runs: r
                .path
                .iter()
                .map(|p| (p.x, p.value.or(p.safe.map(|s| if s { 1.0 } else { 0.0 }))))
                .collect(),
            found: r.conclusion.as_ref().and_then(|c| c.best),
            interval: r.conclusion.as_ref().and_then(|c| c.interval),
        })
        .collect()
}

/// The Δ*_NNL that ellipsoid searches minimising the τ_c of `clock` have found, as Fig. 11
/// draws them beside the grids' minima, and how many searches of Δ_NNL minimised the other
/// clock's τ_c (not drawn). A search still running, or one that found nothing usable, has no
/// minimum yet; one whose best run lies at an end of its range has only a bound (as a grid's
/// edge).
pub fn fig11_minima(
    rows: &[SearchRow],
    clock: report::Clock,
    unit: report::LengthUnit,
) -> (Vec<report::LocatedMinimum>, usize) {
    let minimises = |r: &SearchRow, clock| {
        r.knob == "delta_nnl" && matches!(&r.goal, TuneGoal::Min(f) if f == tau_c_field(clock))
    };
    let other = match clock {
        report::Clock::Cpu => report::Clock::Wall,
        report::Clock::Wall => report::Clock::Cpu,
    };
    let minima = rows
        .iter()
        .filter(|r| r.shape == "ellipsoid" && minimises(r, clock))
        .filter_map(|r| {
            let c = r.conclusion.as_ref()?;
            let (best, [lo, hi], objective) = (c.best?, c.interval?, c.objective?);
            let at_end = |end: f64| ((objective.x / end).ln()).abs() < 1e-9;
            let length = |x: f64| unit.convert(x, r.x0);
            Some(report::LocatedMinimum {
                x0: r.x0,
                phi: r.phi,
                n: u32::try_from(r.n).ok()?,
                delta_star: length(best),
                delta_star_sigma: best,
                interval: Some([length(lo), length(hi)]),
                tau_c_us: objective.mean,
                bracketed: !at_end(r.range[0]) && !at_end(r.range[1]),
                method: report::MinimumMethod::Search,
                grid: [length(r.range[0]), length(r.range[1])],
                update_share: None,
            })
        })
        .collect();
    (minima, rows.iter().filter(|r| minimises(r, other)).count())
}
