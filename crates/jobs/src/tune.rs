//! `[[tune]]` tables: a search of one knob per state point, the state points swept as an
//! `[[edmd]]` table would sweep them (the keys other than the search's own are an `[[edmd]]`
//! table's, read by the same function).
//!
//! A search's evaluations are ordinary EDMD jobs: its template scene with the knob set to the
//! value evaluated and the seed advanced by the repeat, so they are content-addressed like any
//! point (a resumed search, or a grid that ran the same scene, is reused).

use std::ops::Range;

use serde::{Deserialize, Serialize};
use toml::de::{DeTable, DeValue};

use crate::JobSpec;
use crate::sweep::Issue;

/// The keys of a `[[tune]]` table that are the search's, not the scene's.
pub(crate) const TUNE_KEYS: &[&str] = &["family", "knob", "range", "goal", "max_evaluations"];

/// The knobs a search may vary: the scene's real-valued accuracy and performance settings.
pub const KNOBS: &[&str] = &["delta_nnl", "eps_d", "nr_tol", "eps_nnl"];

/// The result fields a search may minimise (fields of an EDMD run's record).
pub const MINIMISED: &[&str] = &[
    "tau_c_us",
    "tau_c_cpu_us",
    "distance_calls_per_collision",
    "nr_iterations_mean",
];

/// Repeats of one value are the template's seed + 0, 1, …: runs whose seed is this far or more
/// from the template's belong to no search.
pub const MAX_REPEAT: u64 = 1000;

/// The default budget of one search, repeats included.
pub const DEFAULT_MAX_EVALUATIONS: u64 = 12;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind", content = "field")]
pub enum TuneGoal {
    /// Minimise this record field.
    Min(String),
    /// The loosest value whose runs stay safe (the accuracy report's rule).
    LoosestSafe,
}

/// One search: one state point of a `[[tune]]` table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TuneSearch {
    pub knob: String,
    pub range: [f64; 2],
    pub goal: TuneGoal,
    pub max_evaluations: u64,
    /// The state point: the scene with the knob at its default and the seed of repeat 0.
    pub template: edmd::Scene,
    /// The plan's `exclusive`: its evaluations are timed alone on the cluster.
    #[serde(default)]
    pub exclusive: bool,
}

impl TuneSearch {
    /// The job that evaluates the knob at `x`, repeat `repeat`.
    pub fn evaluation(&self, x: f64, repeat: u32) -> JobSpec {
        let mut scene = self.template.clone();
        set_knob(&mut scene, &self.knob, x);
        scene.seed = self.template.seed + u64::from(repeat);
        JobSpec::Edmd(scene)
    }

    /// Whether `scene` is one of this search's evaluations (the template but for the knob and a
    /// seed within `MAX_REPEAT` of its own): the knob's value and the repeat.
    pub fn evaluates(&self, scene: &edmd::Scene) -> Option<(f64, u32)> {
        let repeat = scene.seed.checked_sub(self.template.seed)?;
        if repeat >= MAX_REPEAT {
            return None;
        }
        let x = knob(scene, &self.knob)?;
        (self.evaluation(x, repeat as u32) == JobSpec::Edmd(scene.clone()))
            .then_some((x, repeat as u32))
    }

    /// What every evaluation of this search has in common: [`state_point_of`] its template.
    pub fn state_point(&self) -> String {
        state_point_of(&self.template, &self.knob)
    }

    /// What the searches that pool their evaluations have in common (a `[[tune]]` table's
    /// searches that differ only in φ and X0, along which a curve's shape varies smoothly): the
    /// search's settings and the state point with the knob, the seed, φ and X0 blanked.
    pub fn pool(&self) -> String {
        let mut blank = self.template.clone();
        set_knob(&mut blank, &self.knob, 0.0);
        blank.seed = 0;
        blank.phi = 0.0;
        blank.x0 = 0.0;
        format!(
            "{} {:?} {:?} {} {} {}",
            self.knob,
            self.range,
            self.goal,
            self.max_evaluations,
            self.exclusive,
            JobSpec::Edmd(blank).id()
        )
    }

    /// A name for the search: its state point without the knob and the seed.
    pub fn id(&self) -> String {
        self.evaluation(self.range[0], 0).id()
    }
}

/// A key for `scene` as a search of `knob` sees it: its hash with that knob and the seed
/// blanked. Two scenes with different keys are never evaluations of one such search; equal keys
/// are candidates that [`TuneSearch::evaluates`] decides.
pub fn state_point_of(scene: &edmd::Scene, knob: &str) -> String {
    let mut blank = scene.clone();
    set_knob(&mut blank, knob, 0.0);
    blank.seed = 0;
    JobSpec::Edmd(blank).id()
}

fn set_knob(scene: &mut edmd::Scene, knob: &str, x: f64) {
    match knob {
        "delta_nnl" => scene.delta_nnl = x,
        "eps_d" => scene.eps_d = x,
        "nr_tol" => scene.nr_tol = x,
        "eps_nnl" => scene.eps_nnl = x,
        _ => {}
    }
}

fn knob(scene: &edmd::Scene, knob: &str) -> Option<f64> {
    match knob {
        "delta_nnl" => Some(scene.delta_nnl),
        "eps_d" => Some(scene.eps_d),
        "nr_tol" => Some(scene.nr_tol),
        "eps_nnl" => Some(scene.eps_nnl),
        _ => None,
    }
}

/// The searches of one `[[tune]]` table; `expand_scenes` is how an `[[edmd]]` table is
/// expanded (called with the table less the search's keys).
pub(crate) fn expand_tune(
    header: Range<usize>,
    table: &DeTable<'_>,
    expand_scenes: &dyn Fn(&DeTable<'_>) -> Result<Vec<JobSpec>, Issue>,
) -> Result<Vec<TuneSearch>, Issue> {
    let string = |key: &str| -> Result<Option<(Range<usize>, String)>, Issue> {
        match table.get(key) {
            None => Ok(None),
            Some(v) => match v.get_ref() {
                DeValue::String(s) => Ok(Some((v.span(), s.trim().to_owned()))),
                other => Err(Issue::new(
                    v.span(),
                    Some(key),
                    format!("expected a string, got {}", other.type_str()),
                )),
            },
        }
    };
    match string("family")? {
        Some((_, family)) if family == "edmd" => {}
        Some((span, family)) => {
            return Err(Issue::new(
                span,
                Some("family"),
                format!("only \"edmd\" can be tuned, not {family:?}"),
            ));
        }
        None => return Err(Issue::new(header, Some("family"), "missing (\"edmd\")")),
    }
    let Some((knob_span, knob)) = string("knob")? else {
        return Err(Issue::new(
            header,
            Some("knob"),
            format!("missing (one of {KNOBS:?})"),
        ));
    };
    if !KNOBS.contains(&knob.as_str()) {
        return Err(Issue::new(
            knob_span,
            Some("knob"),
            format!("{knob:?} is not a knob a search can vary (one of {KNOBS:?})"),
        ));
    }
    if let Some(written) = table.get(knob.as_str()) {
        return Err(Issue::new(
            written.span(),
            Some(&knob),
            "is the knob searched: its values come from `range`, remove this key",
        ));
    }
    let range = range(header.clone(), table)?;
    let goal = match string("goal")? {
        None => {
            return Err(Issue::new(
                header,
                Some("goal"),
                "missing (\"min tau_c_us\" or \"loosest safe\")",
            ));
        }
        Some((_, goal)) if goal == "loosest safe" => TuneGoal::LoosestSafe,
        Some((span, goal)) => match goal.strip_prefix("min ").map(str::trim) {
            Some(field) if MINIMISED.contains(&field) => TuneGoal::Min(field.to_owned()),
            _ => {
                return Err(Issue::new(
                    span,
                    Some("goal"),
                    format!(
                        "expected \"loosest safe\" or \"min FIELD\" with FIELD one of {MINIMISED:?}, got {goal:?}"
                    ),
                ));
            }
        },
    };
    if goal == TuneGoal::LoosestSafe && knob == "delta_nnl" {
        return Err(Issue::new(
            knob_span,
            Some("knob"),
            "\"loosest safe\" is for accuracy knobs (eps_d, nr_tol, eps_nnl); Δ_NNL changes no \
             result, only its cost: use \"min tau_c_us\"",
        ));
    }
    let max_evaluations = match table.get("max_evaluations") {
        None => DEFAULT_MAX_EVALUATIONS,
        Some(v) => match v
            .get_ref()
            .as_integer()
            .and_then(|i| i.as_str().replace('_', "").parse::<u64>().ok())
        {
            Some(n) if (3..=1000).contains(&n) => n,
            _ => {
                return Err(Issue::new(
                    v.span(),
                    Some("max_evaluations"),
                    "expected a whole number within 3–1000",
                ));
            }
        },
    };
    let mut scene_table = DeTable::new();
    for (key, value) in table.iter() {
        if !TUNE_KEYS.contains(&key.get_ref().as_ref()) {
            scene_table.insert(key.clone(), value.clone());
        }
    }
    let range_span = table.get("range").map_or(header.clone(), |v| v.span());
    expand_scenes(&scene_table)?
        .into_iter()
        .map(|spec| match spec {
            JobSpec::Edmd(template) => {
                let search = TuneSearch {
                    knob: knob.clone(),
                    range,
                    goal: goal.clone(),
                    max_evaluations,
                    template,
                    exclusive: false,
                };
                // Every bound a scene puts on a knob is one-sided (ε_d below the smallest
                // semi-axis, tolerances positive): the range's ends are runnable, so is all of it.
                for end in range {
                    if let JobSpec::Edmd(scene) = search.evaluation(end, 0)
                        && let Err(e) = scene.validate()
                    {
                        return Err(Issue::new(
                            range_span.clone(),
                            Some("range"),
                            format!("{knob} = {end} makes a scene that cannot run: {e}"),
                        ));
                    }
                }
                Ok(search)
            }
            _ => Err(Issue::new(
                header.clone(),
                None,
                "a [[tune]] table expands to EDMD scenes only",
            )),
        })
        .collect()
}

fn range(header: Range<usize>, table: &DeTable<'_>) -> Result<[f64; 2], Issue> {
    let fail = |span, message: &str| Err(Issue::new(span, Some("range"), message));
    let Some(value) = table.get("range") else {
        return fail(header, "missing ([lo, hi], searched in log space)");
    };
    let DeValue::Array(items) = value.get_ref() else {
        return fail(value.span(), "expected [lo, hi]");
    };
    let bounds: Vec<f64> = items
        .iter()
        .filter_map(|item| match item.get_ref() {
            DeValue::Float(f) => f.as_str().replace('_', "").parse().ok(),
            DeValue::Integer(i) => i.as_str().replace('_', "").parse().ok(),
            _ => None,
        })
        .collect();
    match bounds[..] {
        [lo, hi] if items.len() == 2 && lo > 0.0 && hi > lo && hi.is_finite() => Ok([lo, hi]),
        _ => fail(
            value.span(),
            "expected [lo, hi] with 0 < lo < hi (searched in log space)",
        ),
    }
}
