//! Plans: the TOML files that describe campaigns, expanded into validated jobs.
//!
//! ```toml
//! name = "table1"          # default: the file's stem
//! exclusive = true         # time one job at a time on a machine (default false)
//! seed = 0                 # part of every overlap point's identity (default 0)
//!
//! [[overlap]]
//! l_star = { from = 1, to = 20 }   # a scalar, a list, or a range {from, to, step = 1}
//! r_star = [0.05, 0.5, 5.0]
//! precision = ["f32", "f64"]
//! ci_target = 0.01         # optional: more sets until each 95 % CI half-width is <= 1 %,
//! time_cap_s = 30          #   or until 30 s of measurement (default 60 s; only with ci_target)
//! visits = 3               # optional: measure every point in 3 visits spread over the campaign
//! plugins = ["plugins/libmine.so"]  # optional: C kernels (include/sweep_overlap.h) timed
//!                          #   beside `algorithms`; paths relative to the plan's folder
//!
//! [[noop]]
//! count = 1000
//!
//! [[edmd]]                 # every key of a scene (crates/edmd/src/scene.rs)
//! shape = "superquadric"
//! n = 512
//! phi = 0.256
//! x0 = [0.5, 2.0]
//! exponents = [[2, 2, 2], [2, 2, 4]]   # a list-valued key: one list is one value,
//!                                      #   a list of lists sweeps it
//!
//! [[command]]              # a foreign program per point (`command_plan`)
//! label = "peer"
//! program = "bin/md"       # relative to the plan file's folder; hashed into every point's id
//! args = ["{n}", "{seed}"]
//! n = [256, 2048]          # every other key is a parameter
//! ```
//!
//! A sweep is the cartesian product of its keys' values; `algorithms` is one set per point,
//! never expanded. `visits` (one number per sweep, 1 to [`MAX_VISITS`]) makes each point that
//! many jobs, leased visit-major (every point's first visit, then every second …), so that
//! reports can pool them with a between-visit term (`overlap::estimate::pool_visits`).
//! `ci_target` and `time_cap_s` then apply to each visit: a job sees only its own blocks, so it
//! stops on its within-visit interval; how much the visits differ is known once they are all
//! done, and it is the reports' interval that shows it. A scene key whose value is itself a list (`exponents = [n, m, p]`) is
//! swept by a list of such lists; lists nested deeper, ranges and a mix of lists and numbers
//! are refused, and so is any list inside the sweep of a single-valued key. A plan is parsed and validated completely before any job exists, and the
//! first problem (in file order within a sweep) is reported as `FILE:LINE:COL: key `k`: reason`.
//! Points that come out identical (same id) are kept once, at their first position.

use std::collections::HashSet;
use std::ops::Range;
use std::path::{Path, PathBuf};

use overlap::{Algorithm, OverlapError, PointSpec, Precision};
use toml::Spanned;
use toml::de::{DeTable, DeValue};

use crate::command_plan::expand_command;
use crate::plugin;
use crate::spec::{JobSpec, NoopSpec};
use crate::states::States;
use crate::sweep::{Issue, Sweep, Written, cartesian};
use crate::tune::{TuneSearch, expand_tune};

/// A plan may not expand to more jobs than this: a campaign that large is a typo.
pub const MAX_JOBS: usize = 1_000_000;
/// More configurations per set than this do not fit a node's memory (48 B each in f64).
pub const MAX_CONFIGURATIONS: u64 = 1_000_000_000;
pub const MAX_REPEATS: u64 = 1000;
/// Reduced lengths above this are below f32 resolution for a unit-thickness cuboid.
pub const MAX_REDUCED_LENGTH: f64 = 10_000.0;
/// A day: the most one point's precision may cost.
pub const MAX_TIME_CAP_S: f64 = 86_400.0;
/// Visits of one overlap point: each is a whole measurement, so more than this is a typo.
pub const MAX_VISITS: u64 = 100;
/// One hour: a no-op job is for testing the orchestrator, not for occupying a core.
pub const MAX_NOOP_DURATION_MS: u64 = 3_600_000;

#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    pub name: String,
    /// The plan asks that no two timed jobs run on one machine at the same time.
    pub exclusive_timing: bool,
    /// Unique by id, in file order.
    pub jobs: Vec<JobSpec>,
    /// The searches of `[[tune]]` tables, one per state point, in file order; their jobs are
    /// issued as they go, not listed in `jobs`.
    pub tunes: Vec<TuneSearch>,
}

/// A plan that cannot be scheduled. Displays as one line: `FILE:LINE:COL: key `k`: reason`
/// (without the key part for TOML syntax errors and plan-wide problems).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{file}:{line}:{column}: {}{message}", key.as_ref().map(|k| format!("key `{k}`: ")).unwrap_or_default())]
pub struct PlanError {
    pub file: String,
    /// 1-based.
    pub line: usize,
    /// 1-based, in characters.
    pub column: usize,
    pub key: Option<String>,
    pub message: String,
}

impl Plan {
    /// Parses and validates `text`; `file_name` is used in error messages and as the default
    /// name, and its folder is where `[[command]]` programs are looked for.
    pub fn parse(text: &str, file_name: &str) -> Result<Plan, PlanError> {
        let dir = Path::new(file_name)
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        parse_document(text, file_name, dir, true).map_err(|issue| locate(issue, text, file_name))
    }

    /// [`Plan::parse`] with the plan's folder given: a plan submitted from another machine or
    /// folder names its programs relative to the folder it was read from. A plan read on
    /// another's behalf (a coordinator's) never opens its plugins: opening a library runs its
    /// initialisers, foreign code that only a worker started with `--allow-commands` may run;
    /// the files are hashed, and a precision a plugin lacks fails its points when they run.
    pub fn parse_in(text: &str, file_name: &str, dir: &Path) -> Result<Plan, PlanError> {
        parse_document(text, file_name, dir, false).map_err(|issue| locate(issue, text, file_name))
    }

    /// Sum of the jobs' [`JobSpec::estimate_seconds`] on one core.
    pub fn estimate_seconds(&self) -> f64 {
        self.jobs.iter().map(JobSpec::estimate_seconds).sum()
    }
}

fn locate(issue: Issue, text: &str, file_name: &str) -> PlanError {
    let before = text.get(..issue.span.start.min(text.len())).unwrap_or(text);
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    // One line whatever the source of the message.
    let message = issue
        .message
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    PlanError {
        file: file_name.to_owned(),
        line,
        column,
        key: issue.key,
        message,
    }
}

/// Plan-wide defaults a sweep may inherit.
pub(crate) struct Defaults {
    pub seed: u64,
    /// The plan file's folder: relative program and state-file paths start there.
    pub dir: PathBuf,
    /// The state files EDMD points start from (`from_state`, relative to the plan's folder).
    pub states: States,
    /// Whether plugins are opened to check their symbols (see [`Plan::parse_in`]).
    pub open_plugins: bool,
}

/// How one `[[kind]]` table (at `header`) becomes jobs. Adding a job kind is: a [`JobSpec`]
/// variant, one function of this type (reading its keys through [`Sweep`]), and a line in
/// [`KINDS`].
type Expand = fn(Range<usize>, &DeTable<'_>, &Defaults) -> Result<Vec<JobSpec>, Issue>;

/// The sweep kinds, by their table name.
const KINDS: &[(&str, Expand)] = &[
    ("overlap", expand_overlap),
    ("noop", expand_noop),
    ("edmd", expand_edmd),
    ("command", expand_command),
];

const TOP_LEVEL: &[&str] = &[
    "name",
    "exclusive",
    "seed",
    "overlap",
    "noop",
    "edmd",
    "command",
    "tune",
];

fn parse_document(
    text: &str,
    file_name: &str,
    dir: &Path,
    open_plugins: bool,
) -> Result<Plan, Issue> {
    let document = DeTable::parse(text)
        .map_err(|e| Issue::new(e.span().unwrap_or(0..0), None, e.message().to_owned()))?;
    let document = document.get_ref();

    let top = Sweep::new("the plan's top level", 0..0, document, TOP_LEVEL)?;

    let name = match document.get("name") {
        Some(value) => match value.get_ref() {
            DeValue::String(s) if !s.trim().is_empty() => s.trim().to_owned(),
            _ => {
                return Err(Issue::new(
                    value.span(),
                    Some("name"),
                    "must be a non-empty string",
                ));
            }
        },
        None => Path::new(file_name)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
    };
    if name.is_empty() {
        return Err(Issue::new(
            0..0,
            Some("name"),
            "missing, and the file name gives none",
        ));
    }
    let exclusive_timing = match document.get("exclusive") {
        Some(value) => match value.get_ref() {
            DeValue::Boolean(b) => *b,
            other => {
                return Err(Issue::new(
                    value.span(),
                    Some("exclusive"),
                    format!("expected true or false, got {}", other.type_str()),
                ));
            }
        },
        None => false,
    };
    let defaults = Defaults {
        seed: top.integer("seed", Some(0), &|_| Ok(()))?,
        dir: dir.to_path_buf(),
        states: States::in_folder(dir),
        open_plugins,
    };

    // Every sweep table, in file order, with its kind.
    let mut sweeps: Vec<(Range<usize>, &DeTable<'_>, Expand)> = Vec::new();
    for &(kind, expand) in KINDS {
        for (header, table) in tables_of(document, kind)? {
            sweeps.push((header, table, expand));
        }
    }
    let mut tunes = Vec::new();
    for (header, table) in tables_of(document, "tune")? {
        let expand =
            |scenes: &DeTable<'_>| expand_scenes("[[tune]]", header.clone(), scenes, &defaults);
        tunes.extend(expand_tune(header.clone(), table, &expand)?);
    }
    if sweeps.is_empty() && tunes.is_empty() {
        return Err(Issue::new(
            0..0,
            None,
            "the plan has no sweeps (add [[overlap]], [[edmd]], [[tune]] or [[noop]] tables)",
        ));
    }
    sweeps.sort_by_key(|(span, _, _)| span.start);

    let mut jobs = Vec::new();
    let mut seen = HashSet::new();
    for (header, table, expand) in sweeps {
        for job in expand(header.clone(), table, &defaults)? {
            if seen.insert(job.id()) {
                jobs.push(job);
            }
        }
        if jobs.len() > MAX_JOBS {
            return Err(Issue::new(
                header,
                None,
                format!("the plan expands to more than {MAX_JOBS} jobs"),
            ));
        }
    }
    for t in tunes.iter_mut() {
        t.exclusive = exclusive_timing;
    }
    Ok(Plan {
        name,
        exclusive_timing,
        jobs,
        tunes,
    })
}

/// The `[[kind]]` tables of the document, each with its span.
fn tables_of<'d, 'i>(
    document: &'d DeTable<'i>,
    kind: &str,
) -> Result<Vec<(Range<usize>, &'d DeTable<'i>)>, Issue> {
    let Some(value) = document.get(kind) else {
        return Ok(Vec::new());
    };
    let tables: Vec<&Spanned<DeValue<'_>>> = match value.get_ref() {
        DeValue::Array(array) => array.iter().collect(),
        DeValue::Table(_) => vec![value],
        other => {
            return Err(Issue::new(
                value.span(),
                Some(kind),
                format!("expected [[{kind}]] tables, got {}", other.type_str()),
            ));
        }
    };
    tables
        .into_iter()
        .map(|table| match table.get_ref() {
            DeValue::Table(t) => Ok((table.span(), t)),
            _ => Err(Issue::new(
                table.span(),
                Some(kind),
                format!("expected [[{kind}]] tables"),
            )),
        })
        .collect()
}

/// Fails when a sweep's product of value counts exceeds [`MAX_JOBS`], before building it.
pub(crate) fn check_product(sweep: &Sweep<'_, '_>, lens: &[usize]) -> Result<(), Issue> {
    let total = lens.iter().try_fold(1usize, |acc, &n| {
        acc.checked_mul(n).filter(|&t| t <= MAX_JOBS)
    });
    match total {
        Some(_) => Ok(()),
        None => Err(Issue::new(
            sweep.header(),
            None,
            format!("the sweep expands to more than {MAX_JOBS} jobs"),
        )),
    }
}

const OVERLAP_KEYS: &[&str] = &[
    "l_star",
    "w_star",
    "r_star",
    "acceptance",
    "configurations",
    "repeats",
    "precision",
    "algorithms",
    "seed",
    "ci_target",
    "time_cap_s",
    "verdict_check",
    "visits",
    "plugins",
];

fn positive_length(x: f64) -> Result<(), String> {
    if x <= 0.0 {
        Err(format!("must be positive, got {x}"))
    } else if x > MAX_REDUCED_LENGTH {
        Err(format!("must be at most {MAX_REDUCED_LENGTH}, got {x}"))
    } else {
        Ok(())
    }
}

fn at_least_one_up_to(max: u64) -> impl Fn(u64) -> Result<(), String> {
    move |n| match n {
        0 => Err("must be at least 1".to_owned()),
        n if n > max => Err(format!("must be at most {max}, got {n}")),
        _ => Ok(()),
    }
}

/// Reason of an `overlap` naming error, without its key (the plan error names the key).
fn reason(e: OverlapError) -> String {
    match e {
        OverlapError::Invalid { reason, .. } => reason,
        other => other.to_string(),
    }
}

fn expand_overlap(
    header: Range<usize>,
    table: &DeTable<'_>,
    defaults: &Defaults,
) -> Result<Vec<JobSpec>, Issue> {
    let sweep = &Sweep::new("[[overlap]]", header, table, OVERLAP_KEYS)?;
    let l_star = sweep.floats("l_star", None, &positive_length)?;
    let w_star = sweep.floats("w_star", None, &positive_length)?;
    let r_star = sweep.floats("r_star", None, &positive_length)?;
    let acceptance = sweep.floats("acceptance", Some(0.4), &|x| {
        if x > 0.0 && x < 1.0 {
            Ok(())
        } else {
            Err(format!("must lie strictly between 0 and 1, got {x}"))
        }
    })?;
    let configurations = sweep.integers(
        "configurations",
        Some(2_000_000),
        &at_least_one_up_to(MAX_CONFIGURATIONS),
    )?;
    let repeats = sweep.integers("repeats", Some(3), &at_least_one_up_to(MAX_REPEATS))?;
    let precision = sweep.names("precision", Precision::F32, &|s| s.parse().map_err(reason))?;
    let algorithms = sweep.name_set("algorithms", Algorithm::ALL.to_vec(), &|s| {
        s.parse().map_err(reason)
    })?;
    let seed = sweep.integers("seed", Some(defaults.seed), &|_| Ok(()))?;
    let ci_target = sweep.optional_floats("ci_target", &|x| {
        if x > 0.0 && x < 1.0 {
            Ok(())
        } else {
            Err(format!(
                "must lie strictly between 0 and 1 (a fraction of the estimate), got {x}"
            ))
        }
    })?;
    let time_cap_s = sweep.optional_floats("time_cap_s", &|x| {
        if x <= 0.0 {
            Err(format!("must be a positive number of seconds, got {x}"))
        } else if x > MAX_TIME_CAP_S {
            Err(format!("must be at most {MAX_TIME_CAP_S} s, got {x}"))
        } else {
            Ok(())
        }
    })?;

    let verdict_check =
        sweep.optional_integers("verdict_check", &at_least_one_up_to(MAX_CONFIGURATIONS))?;
    // One number for the sweep, not swept: visits are repeats of a point, not a parameter of it.
    let visits = sweep.integer("visits", Some(1), &at_least_one_up_to(MAX_VISITS))?;
    // One set per point, like `algorithms`: each file hashed and opened once, here.
    let plugins = sweep.name_set("plugins", Vec::new(), &|written| {
        plugin::resolve(&defaults.dir, written, defaults.open_plugins).map_err(|e| e.to_string())
    })?;

    let lens = [
        seed.len(),
        precision.len(),
        r_star.len(),
        l_star.len(),
        w_star.len(),
        acceptance.len(),
        configurations.len(),
        repeats.len(),
        ci_target.len(),
        time_cap_s.len(),
        verdict_check.len(),
    ];
    check_product(sweep, &lens)?;
    // `visits` multiplies the sweep: checked on the product, before anything is built.
    let points_and_visits = lens
        .iter()
        .try_fold(1usize, |acc, &n| acc.checked_mul(n))
        .and_then(|n| n.checked_mul(usize::try_from(visits).ok()?))
        .filter(|&n| n <= MAX_JOBS);
    if points_and_visits.is_none() {
        return Err(Issue::new(
            sweep.span_of("visits"),
            Some("visits"),
            format!("the sweep's points times its visits exceed {MAX_JOBS} jobs"),
        ));
    }
    let points = cartesian(&lens)
        .map(|i| {
            let point = PointSpec {
                seed: seed[i[0]],
                precision: precision[i[1]],
                r_star: r_star[i[2]],
                l_star: l_star[i[3]],
                w_star: w_star[i[4]],
                acceptance: acceptance[i[5]],
                configurations: configurations[i[6]],
                // Bounded by MAX_REPEATS above.
                repeats: u32::try_from(repeats[i[7]]).unwrap_or(u32::MAX),
                algorithms: algorithms.clone(),
                ci_target: ci_target[i[8]],
                time_cap_s: time_cap_s[i[9]],
                verdict_check: verdict_check[i[10]],
                visit: None,
                plugins: plugins.iter().map(|p| p.file.clone()).collect(),
            };
            // The kernel crate's own rules, so that a rule added there is enforced here too.
            point.validate().map_err(|e| match e {
                OverlapError::Invalid { key, reason } => {
                    Issue::new(sweep.span_of(key), Some(key), reason)
                }
                other => Issue::new(sweep.header(), None, other.to_string()),
            })?;
            if let Some(missing) = plugins.iter().find(|p| !p.exports(point.precision)) {
                return Err(Issue::new(
                    sweep.span_of("plugins"),
                    Some("plugins"),
                    format!(
                        "plugin {} does not export `{}`, needed for the sweep's {} points",
                        missing.file.path,
                        plugin::symbol(point.precision),
                        point.precision
                    ),
                ));
            }
            Ok(point)
        })
        .collect::<Result<Vec<PointSpec>, Issue>>()?;
    Ok(visit_major(points, visits))
}

/// Every point's first visit, then every point's second, and so on: the order the store leases
/// them in too ([`JobSpec::pass`]), so that the visits of one point are a whole pass over the
/// sweep apart in time and see different states of the machine. The first visit is the point
/// as it was before visits existed (same id); later ones carry `visit` and are new jobs. The
/// verdict check is about the kernels' answers, not their speed: only the first visit runs it.
fn visit_major(points: Vec<PointSpec>, visits: u64) -> Vec<JobSpec> {
    let mut jobs = Vec::with_capacity(points.len() * visits as usize);
    jobs.extend(points.iter().cloned().map(JobSpec::Overlap));
    for visit in 1..visits {
        // Bounded by MAX_VISITS.
        let visit = u32::try_from(visit).unwrap_or(u32::MAX);
        jobs.extend(points.iter().map(|point| {
            JobSpec::Overlap(PointSpec {
                visit: Some(visit),
                verdict_check: None,
                ..point.clone()
            })
        }));
    }
    jobs
}

fn expand_noop(
    header: Range<usize>,
    table: &DeTable<'_>,
    _: &Defaults,
) -> Result<Vec<JobSpec>, Issue> {
    let sweep = &Sweep::new(
        "[[noop]]",
        header,
        table,
        &["count", "duration_ms", "fail_rate"],
    )?;
    let count = sweep.integer("count", None, &at_least_one_up_to(MAX_JOBS as u64))?;
    let duration_ms = sweep.integers("duration_ms", Some(0), &|n| {
        if n > MAX_NOOP_DURATION_MS {
            Err(format!("must be at most {MAX_NOOP_DURATION_MS}, got {n}"))
        } else {
            Ok(())
        }
    })?;
    let fail_rate = sweep.floats("fail_rate", Some(0.0), &|x| {
        if (0.0..=1.0).contains(&x) {
            Ok(())
        } else {
            Err(format!("must lie in [0, 1], got {x}"))
        }
    })?;
    let lens = [
        duration_ms.len(),
        fail_rate.len(),
        usize::try_from(count).unwrap_or(usize::MAX),
    ];
    check_product(sweep, &lens)?;
    Ok(cartesian(&lens)
        .map(|i| {
            JobSpec::Noop(NoopSpec {
                duration_ms: duration_ms[i[0]],
                fail_rate: fail_rate[i[1]],
                index: i[2] as u64,
            })
        })
        .collect())
}

/// EDMD points: every key of a scene (the `edmd` crate defines them, their defaults and their
/// checks); each may be a list or a range, and the sweep is their cartesian product. A key whose
/// value is itself a list (`exponents = [n, m, p]`) takes one list, or a list of lists to sweep.
fn expand_edmd(
    header: Range<usize>,
    table: &DeTable<'_>,
    defaults: &Defaults,
) -> Result<Vec<JobSpec>, Issue> {
    expand_scenes("[[edmd]]", header, table, defaults)
}

/// The scenes of a table of scene keys (`what` names the table in errors).
fn expand_scenes(
    what: &str,
    header: Range<usize>,
    table: &DeTable<'_>,
    defaults: &Defaults,
) -> Result<Vec<JobSpec>, Issue> {
    let keys = edmd_keys();
    let known: Vec<&str> = keys.iter().map(|(key, _)| key.as_str()).collect();
    let sweep = &Sweep::new(what, header.clone(), table, &known)?;
    // Each key's values, each with where it was written.
    let mut columns: Vec<(&str, Vec<Written>)> = Vec::new();
    for (key, list_valued) in &keys {
        let key = key.as_str();
        let values = if *list_valued {
            sweep.lists(key)?
        } else {
            sweep.values(key)?
        };
        if let Some(values) = values {
            for (span, value) in &values {
                check_scene_value(key, value)
                    .map_err(|reason| Issue::new(span.clone(), Some(key), reason))?;
            }
            columns.push((key, values));
        }
    }
    let has = |key: &str| columns.iter().any(|(k, _)| *k == key);
    for key in EDMD_REQUIRED {
        // A mixture's shape is its species' (edmd::fill_shape_defaults).
        let given = has(key) || (key == "shape" && has("species"));
        if !given {
            return Err(Issue::new(
                header,
                Some(key),
                "missing (this key has no default)",
            ));
        }
    }
    if !columns.iter().any(|(k, _)| *k == "seed") {
        let seed = toml::Value::Integer(defaults.seed as i64);
        columns.push(("seed", vec![(header.clone(), seed)]));
    }
    let lens: Vec<usize> = columns.iter().map(|(_, v)| v.len()).collect();
    check_product(sweep, &lens)?;
    cartesian(&lens)
        .map(|i| {
            let point: Vec<(&str, &Written)> = columns
                .iter()
                .zip(&i)
                .map(|((key, values), &k)| (*key, &values[k]))
                .collect();
            // A value that is wrong only with the others of its point is shown where it was
            // written (the list element, not the key).
            let written = |key: &str| {
                point
                    .iter()
                    .find(|(k, _)| *k == key)
                    .map_or_else(|| sweep.span_of(key), |(_, (span, _))| span.clone())
            };
            let mut table: toml::Table = point
                .iter()
                .map(|(key, (_, value))| (key.to_string(), value.clone()))
                .collect();
            edmd::fill_shape_defaults(&mut table);
            // A state file becomes its absolute path and its hash, which names the point.
            if let Some(toml::Value::String(written_path)) = table.get("from_state") {
                let (path, hash) = defaults.states.resolve(written_path).map_err(|reason| {
                    Issue::new(written("from_state"), Some("from_state"), reason)
                })?;
                table.insert("from_state".into(), toml::Value::String(path));
                table.insert("from_state_blake3".into(), toml::Value::String(hash));
            }
            let scene: edmd::Scene =
                toml::Value::Table(table)
                    .try_into()
                    .map_err(|e: toml::de::Error| {
                        Issue::new(header.clone(), None, format!("{what}: {}", e.message()))
                    })?;
            scene.validate().map_err(|e| match e {
                edmd::SceneError::Invalid { key, reason, .. } => {
                    Issue::new(written(key), Some(key), reason)
                }
                other => Issue::new(header.clone(), None, other.to_string()),
            })?;
            defaults
                .states
                .check(&scene)
                .map_err(|reason| Issue::new(written("from_state"), Some("from_state"), reason))?;
            Ok(JobSpec::Edmd(scene))
        })
        .collect()
}

/// The keys of a scene that have no default.
const EDMD_REQUIRED: [&str; 3] = ["shape", "n", "phi"];

/// Whether `value` has the type (and, for names, the variant) of the scene key `key`, tried alone
/// in an otherwise valid scene, so that the plan error names the key rather than the table.
fn check_scene_value(key: &str, value: &toml::Value) -> Result<(), String> {
    let mut probe = toml::Table::new();
    probe.insert("shape".into(), toml::Value::String("ellipsoid".into()));
    probe.insert("n".into(), toml::Value::Integer(2));
    probe.insert("phi".into(), toml::Value::Float(0.1));
    probe.insert(key.to_owned(), value.clone());
    edmd::fill_shape_defaults(&mut probe);
    toml::Value::Table(probe)
        .try_into::<edmd::Scene>()
        .map(|_| ())
        .map_err(|e| e.message().to_owned())
}

/// The keys of a scene, each with whether its value is itself a list, read off a serialised
/// default one, so this list cannot drift from the `edmd` crate (a superquadric's, the only one
/// that serialises every key, `exponents` included).
fn edmd_keys() -> Vec<(String, bool)> {
    let scene = edmd::Scene {
        from_state: Some(String::new()),
        species: Some(Vec::new()),
        ..edmd::Scene::new(edmd::ShapeKind::Superquadric, 2, 0.1)
    };
    match toml::Table::try_from(&scene) {
        // The state file's hash is computed from the file, not written in plans.
        Ok(table) => table
            .into_iter()
            .filter(|(key, _)| key != "from_state_blake3")
            .map(|(key, value)| (key, value.is_array()))
            .collect(),
        Err(_) => Vec::new(),
    }
}
