//! Plans: validation messages, expansion counts, identity rules.

use std::collections::BTreeSet;
use std::path::PathBuf;

use jobs::{JobSpec, Plan};
use overlap::{Algorithm, Precision};
use proptest::prelude::*;

fn deploy_plan(name: &str) -> Plan {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../deploy/plans")
        .join(name);
    let text = std::fs::read_to_string(&path).expect("the deploy plans are in the repository");
    Plan::parse(&text, name).unwrap_or_else(|e| panic!("{e}"))
}

fn ids(plan: &Plan) -> BTreeSet<String> {
    plan.jobs.iter().map(JobSpec::id).collect()
}

fn parse(text: &str) -> Plan {
    Plan::parse(text, "p.toml").unwrap_or_else(|e| panic!("{e}"))
}

const GOOD: &str = "l_star = 1\nw_star = 1\nr_star = 0.5\n";

/// (plan, key named in the message, line of the error). `None`: the message names no key.
const BAD: &[(&str, Option<&str>, usize)] = &[
    (
        "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = 0.5\nci_target = 1.5\n",
        Some("ci_target"),
        5,
    ),
    (
        "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = 0.5\nci_target = 0.01\ntime_cap_s = 0\n",
        Some("time_cap_s"),
        6,
    ),
    (
        "[[overlap]]\nl_star = 1\ntime_cap_s = 30\nw_star = 1\nr_star = 0.5\n",
        Some("time_cap_s"),
        3,
    ),
    (
        "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = 0.5\nfoo = 3\n",
        Some("foo"),
        5,
    ),
    (
        "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = 0.5\nacceptance = 1.5\n",
        Some("acceptance"),
        5,
    ),
    (
        "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = 0.5\nacceptance = 0\n",
        Some("acceptance"),
        5,
    ),
    (
        "[[overlap]]\nacceptance = \"high\"\nl_star = 1\nw_star = 1\nr_star = 0.5\n",
        Some("acceptance"),
        2,
    ),
    (
        "[[overlap]]\nl_star = -1\nw_star = 1\nr_star = 0.5\n",
        Some("l_star"),
        2,
    ),
    (
        "[[overlap]]\nl_star = 1\nw_star = [1, 0]\nr_star = 0.5\n",
        Some("w_star"),
        3,
    ),
    (
        "[[overlap]]\nl_star = 20000\nw_star = 1\nr_star = 0.5\n",
        Some("l_star"),
        2,
    ),
    (
        "[[overlap]]\nl_star = nan\nw_star = 1\nr_star = 0.5\n",
        Some("l_star"),
        2,
    ),
    (
        "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = []\n",
        Some("r_star"),
        4,
    ),
    (
        "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = [0.5, [1]]\n",
        Some("r_star"),
        4,
    ),
    (
        "[[overlap]]\nl_star = 1\nw_star = 1\n\nr_star = 0.5\nconfigurations = 0\n",
        Some("configurations"),
        6,
    ),
    (
        "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = 0.5\nconfigurations = 2_000_000_000\n",
        Some("configurations"),
        5,
    ),
    (
        "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = 0.5\nconfigurations = -5\n",
        Some("configurations"),
        5,
    ),
    (
        "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = 0.5\nrepeats = 0\n",
        Some("repeats"),
        5,
    ),
    (
        "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = 0.5\nrepeats = 2.5\n",
        Some("repeats"),
        5,
    ),
    (
        "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = 0.5\nalgorithms = [\"arvo\", \"gjk\"]\n",
        Some("algorithms"),
        5,
    ),
    (
        "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = 0.5\nalgorithms = [\"qri\", \"qri\"]\n",
        Some("algorithms"),
        5,
    ),
    (
        "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = 0.5\nalgorithms = []\n",
        Some("algorithms"),
        5,
    ),
    (
        "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = 0.5\nprecision = \"f16\"\n",
        Some("precision"),
        5,
    ),
    (
        "[[overlap]]\nl_star = { from = 1, to = 20, step = 0 }\nw_star = 1\nr_star = 0.5\n",
        Some("l_star"),
        2,
    ),
    (
        "[[overlap]]\nl_star = 1\nw_star = { from = 5, to = 1 }\nr_star = 0.5\n",
        Some("w_star"),
        3,
    ),
    (
        "[[overlap]]\nl_star = { from = 1, upto = 3 }\nw_star = 1\nr_star = 0.5\n",
        Some("l_star"),
        2,
    ),
    (
        "[[overlap]]\nl_star = { to = 3 }\nw_star = 1\nr_star = 0.5\n",
        Some("l_star"),
        2,
    ),
    (
        "[[overlap]]\nl_star = { from = 1, to = 1e9, step = 1e-3 }\nw_star = 1\nr_star = 0.5\n",
        Some("l_star"),
        2,
    ),
    (
        "name = \"x\"\n\n[[overlap]]\nw_star = 1\nr_star = 0.5\n",
        Some("l_star"),
        3,
    ),
    (
        "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = 0.5\nseed = -1\n",
        Some("seed"),
        5,
    ),
    ("nmae = \"x\"\n[[noop]]\ncount = 1\n", Some("nmae"), 1),
    (
        "exclusive = \"yes\"\n[[noop]]\ncount = 1\n",
        Some("exclusive"),
        1,
    ),
    ("name = \"\"\n[[noop]]\ncount = 1\n", Some("name"), 1),
    ("[[noop]]\ncount = 0\n", Some("count"), 2),
    ("[[noop]]\ncount = [1, 2]\n", Some("count"), 2),
    (
        "[[noop]]\ncount = 10\nfail_rate = 1.5\n",
        Some("fail_rate"),
        3,
    ),
    (
        "[[noop]]\ncount = 10\nduration_ms = -1\n",
        Some("duration_ms"),
        3,
    ),
    ("[[noop]]\ncount = 2000000\n", Some("count"), 2),
    ("overlap = 3\n", Some("overlap"), 1),
    (
        "[[noop]]\ncount = 1\n\n[[edmd]]\nshape = \"sphere\"\n",
        Some("n"),
        4,
    ),
    ("[[noop]]\ncount = 1\nduration_ms = [1,\n", None, 3),
    (
        "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = 0.5\nvisits = 0\n",
        Some("visits"),
        5,
    ),
    (
        "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = 0.5\nvisits = [1, 3]\n",
        Some("visits"),
        5,
    ),
    (
        "[[overlap]]\nl_star = 1\nw_star = 1\nr_star = 0.5\nvisits = 101\n",
        Some("visits"),
        5,
    ),
    ("name = \"empty\"\n", None, 1),
];

#[test]
fn bad_plans_name_the_key_and_the_line() {
    assert!(BAD.len() >= 15);
    for &(text, key, line) in BAD {
        let error = Plan::parse(text, "bad.toml").expect_err(text).to_string();
        assert!(!error.contains('\n'), "one line: {error}");
        assert!(
            error.starts_with(&format!("bad.toml:{line}:")),
            "line {line} for {text:?}: {error}"
        );
        match key {
            Some(key) => assert!(
                error.contains(&format!("key `{key}`: ")),
                "key `{key}` for {text:?}: {error}"
            ),
            None => assert!(!error.contains("key `"), "{error}"),
        }
    }
}

#[test]
fn messages_read_as_documented() {
    let text =
        "name = \"t\"\n[[overlap]]\nl_star = 1\nw_star = 1\nr_star = 0.5\nacceptance = 1.5\n";
    let error = Plan::parse(text, "t.toml").expect_err("acceptance 1.5 is out of range");
    assert_eq!(
        error.to_string(),
        "t.toml:6:14: key `acceptance`: must lie strictly between 0 and 1, got 1.5"
    );
    assert_eq!(
        (error.line, error.column, error.key.as_deref()),
        (6, 14, Some("acceptance"))
    );
    let edmd = Plan::parse(
        "[[edmd]]\nshape = \"ellipsoid\"\nn = 256\nphi = [0.3, 0.95]\n",
        "e.toml",
    )
    .expect_err("φ above close packing");
    // EDMD values are shown where they were written, the list element, as overlap ones are.
    assert!(
        edmd.to_string().starts_with("e.toml:4:13: key `phi`: "),
        "{edmd}"
    );
    let list = Plan::parse(
        "[[overlap]]\nl_star = [1, 2, -3]\nw_star = 1\nr_star = 1\n",
        "l.toml",
    )
    .expect_err("-3");
    assert_eq!(
        list.to_string(),
        "l.toml:2:17: key `l_star`: must be positive, got -3"
    );
}

#[test]
fn deploy_plans_expand_to_the_papers_campaigns() {
    let table1 = deploy_plan("table1.toml");
    assert_eq!(table1.name, "table1");
    assert!(table1.exclusive_timing);
    assert_eq!(table1.jobs.len(), 20 * 20 * 3 * 2);
    assert_eq!(
        ids(&table1).len(),
        2400,
        "distinct points have distinct ids"
    );
    for job in &table1.jobs {
        let JobSpec::Overlap(p) = job else {
            panic!("overlap only")
        };
        assert_eq!(
            (p.configurations, p.repeats, p.acceptance, p.seed),
            (2_000_000, 3, 0.4, 0)
        );
        assert_eq!(p.algorithms, Algorithm::ALL);
    }
    // About 1.5 s per point on one core by the model: an hour in all; a sanity bound only.
    assert!(
        (1_000.0..10_000.0).contains(&table1.estimate_seconds()),
        "{}",
        table1.estimate_seconds()
    );

    let quick = deploy_plan("quick.toml");
    assert_eq!(quick.jobs.len(), 4 * 4 * 3 * 2);
    assert!(
        quick.estimate_seconds() < 60.0,
        "{} s",
        quick.estimate_seconds()
    );
    let noop = deploy_plan("noop.toml");
    assert_eq!(noop.jobs.len(), 1000);
    assert_eq!(ids(&noop).len(), 1000);
}

/// `ci_target` and `time_cap_s` expand like any key (what precision costs is a sweep), default
/// to unset, and unset they leave a point's id as it was before they existed.
#[test]
fn precision_keys_expand_and_default_to_unset() {
    let plan = parse(&format!(
        "[[overlap]]\n{GOOD}ci_target = [0.01, 0.003]\ntime_cap_s = 30\n"
    ));
    let targets: Vec<(Option<f64>, Option<f64>)> = plan
        .jobs
        .iter()
        .map(|j| match j {
            JobSpec::Overlap(p) => (p.ci_target, p.time_cap_s),
            _ => panic!("overlap only"),
        })
        .collect();
    assert_eq!(
        targets,
        [(Some(0.01), Some(30.0)), (Some(0.003), Some(30.0))]
    );
    let plain = parse(&format!("[[overlap]]\n{GOOD}"));
    let JobSpec::Overlap(p) = &plain.jobs[0] else {
        panic!()
    };
    assert_eq!((p.ci_target, p.time_cap_s), (None, None));
    assert!(!plain.jobs[0].canonical_json().contains("ci_target"));
}

#[test]
fn defaults_and_name_from_file() {
    let plan = Plan::parse(&format!("[[overlap]]\n{GOOD}"), "dir/my-plan.toml").expect("valid");
    assert_eq!(plan.name, "my-plan");
    assert!(!plan.exclusive_timing);
    let [JobSpec::Overlap(p)] = &plan.jobs[..] else {
        panic!("one point: {:?}", plan.jobs)
    };
    assert_eq!(
        (p.configurations, p.repeats, p.acceptance, p.seed),
        (2_000_000, 3, 0.4, 0)
    );
    assert_eq!(
        (p.precision, p.algorithms.as_slice()),
        (Precision::F32, &Algorithm::ALL[..])
    );
    // A float with no fractional part is a whole number.
    let plan = parse(&format!("[[overlap]]\n{GOOD}configurations = 2e6\n"));
    let JobSpec::Overlap(p) = &plan.jobs[0] else {
        panic!()
    };
    assert_eq!(p.configurations, 2_000_000);
}

#[test]
fn float_ranges_land_on_decimals() {
    let plan = parse(
        "[[overlap]]\nl_star = { from = 0.05, to = 1, step = 0.05 }\nw_star = 1\nr_star = { from = 0.1, to = 0.3, step = 0.1 }\n",
    );
    let mut l = BTreeSet::new();
    let mut r = BTreeSet::new();
    for job in &plan.jobs {
        let JobSpec::Overlap(p) = job else { panic!() };
        l.insert(p.l_star.to_bits());
        r.insert(p.r_star.to_bits());
    }
    let expected_l: BTreeSet<u64> = (1..=20)
        .map(|k| format!("{}", k as f64 * 0.05).parse::<f64>())
        .map(|x| x.expect("a number"))
        .map(|x| {
            format!("{x:.11e}")
                .parse::<f64>()
                .expect("a number")
                .to_bits()
        })
        .collect();
    assert_eq!(l, expected_l);
    assert!(
        l.contains(&1.0f64.to_bits()) && l.contains(&0.15f64.to_bits()),
        "0.15, not 0.15000000000000002"
    );
    let r_expected: BTreeSet<u64> = [0.1f64, 0.2, 0.3].iter().map(|x| x.to_bits()).collect();
    assert_eq!(r, r_expected);
    assert_eq!(plan.jobs.len(), 20 * 3);
}

#[test]
fn ids_ignore_key_order_list_order_and_number_spelling() {
    let a = parse(
        "seed = 0\n[[overlap]]\nl_star = [4, 8]\nw_star = { from = 1, to = 3 }\nr_star = [0.05, 5]\n\
         precision = [\"f32\", \"f64\"]\nalgorithms = [\"qri\", \"ocsi\"]\nconfigurations = 1000\n",
    );
    let b = parse(
        "[[overlap]]\nconfigurations = 1_000\nalgorithms = [\"ocsi\", \"qri\"]\nprecision = [\"f64\", \"f32\"]\n\
         r_star = [5.0, 0.05]\nw_star = [3.0, 2, 1]\nl_star = [8.0, 4.0]\nacceptance = 0.4\nrepeats = 3\n",
    );
    assert_eq!(a.jobs.len(), 2 * 3 * 2 * 2);
    assert_eq!(ids(&a), ids(&b));
    // The plan's seed is a parameter: another seed, other points (and other generator streams).
    let c = parse(&a_with_seed(7));
    assert!(ids(&a).is_disjoint(&ids(&c)));
    let seeds: BTreeSet<u64> = a
        .jobs
        .iter()
        .chain(&c.jobs)
        .map(JobSpec::generator_seed)
        .collect();
    assert_eq!(seeds.len(), a.jobs.len() * 2);
}

fn a_with_seed(seed: u64) -> String {
    format!(
        "seed = {seed}\n[[overlap]]\nl_star = [4, 8]\nw_star = {{ from = 1, to = 3 }}\nr_star = [0.05, 5]\n\
         precision = [\"f32\", \"f64\"]\nalgorithms = [\"qri\", \"ocsi\"]\nconfigurations = 1000\n"
    )
}

#[test]
fn adding_a_value_adds_exactly_the_new_points() {
    let before = parse("[[overlap]]\nl_star = [1, 2]\nw_star = [1, 2]\nr_star = [0.05, 0.5]\n");
    let after = parse("[[overlap]]\nl_star = [1, 2]\nw_star = [1, 2]\nr_star = [0.05, 0.5, 5]\n");
    let only_new = parse("[[overlap]]\nl_star = [1, 2]\nw_star = [1, 2]\nr_star = 5\n");
    let added: BTreeSet<String> = ids(&after).difference(&ids(&before)).cloned().collect();
    assert!(ids(&before).is_subset(&ids(&after)));
    assert_eq!(added, ids(&only_new));
    assert_eq!(added.len(), 4);
}

#[test]
fn identical_points_are_kept_once_and_seeds_expand() {
    let twice = parse(&format!(
        "[[overlap]]\n{GOOD}\n[[overlap]]\nl_star = 1\nw_star = 1.0\nr_star = [0.5, 1]\n"
    ));
    assert_eq!(twice.jobs.len(), 2, "{:?}", twice.jobs);
    let replicas = parse(&format!("[[overlap]]\n{GOOD}seed = [0, 1, 2]\n"));
    assert_eq!(ids(&replicas).len(), 3);
    let noop = parse(
        "[[noop]]\ncount = 5\nduration_ms = [0, 10]\nfail_rate = 0.1\n[[noop]]\ncount = 5\nfail_rate = 0.1\n",
    );
    assert_eq!(
        noop.jobs.len(),
        10,
        "the second sweep repeats the first's duration_ms = 0 points"
    );
}

/// `[[edmd]]` sweeps expand every list-valued scene key, and the `edmd` crate's own checks name
/// the key and its line.
#[test]
fn edmd_sweeps_expand_and_are_checked_by_the_engine() {
    let plan = Plan::parse(
        "[[edmd]]\nshape = \"ellipsoid\"\nn = 256\nphi = [0.3, 0.4]\nx0 = { from = 1, to = 3 }\nneighbours = [\"ll\", \"nnl\"]\ncollisions = 1000\n",
        "e.toml",
    )
    .unwrap();
    assert_eq!(plan.jobs.len(), 2 * 3 * 2);
    let ids: std::collections::HashSet<String> = plan.jobs.iter().map(|j| j.id()).collect();
    assert_eq!(ids.len(), 12);
    assert!(plan.jobs.iter().all(|j| j.kind() == "edmd"));
    for (text, needle) in [
        (
            "[[edmd]]\nshape = \"ellipsoid\"\nn = 256\nphi = 0.3\nx0 = [2, 0]\n",
            "e.toml:5:10: key `x0`",
        ),
        (
            "[[edmd]]\nshape = \"sphere\"\nn = 1\nphi = 0.3\n",
            "e.toml:3:5: key `n`",
        ),
        (
            "[[edmd]]\nshape = \"sphere\"\nn = 8\nphi = 0.3\neps_d = -1e-5\n",
            "e.toml:5:9: key `eps_d`",
        ),
        (
            "[[edmd]]\nshape = \"sphere\"\nn = 8\nphi = 0.3\ncolour = 1\n",
            "e.toml:5:1: key `colour`",
        ),
        (
            "[[edmd]]\nshape = \"cube\"\nn = 8\nphi = 0.3\n",
            "e.toml:2:9: key `shape`: unknown variant `cube`",
        ),
        (
            "[[edmd]]\nshape = \"sphere\"\nn = 8\nphi = 0.3\nneighbours = [\"ll\", \"cells\"]\n",
            "e.toml:5:21: key `neighbours`: unknown variant `cells`",
        ),
        (
            "[[edmd]]\nshape = \"sphere\"\nn = 8\nphi = 0.3\ncollisions = \"many\"\n",
            "e.toml:5:14: key `collisions`",
        ),
        (
            "[[edmd]]\nshape = \"sphere\"\nphi = 0.3\n",
            "e.toml:1:1: key `n`: missing",
        ),
    ] {
        let err = Plan::parse(text, "e.toml").expect_err(text).to_string();
        assert!(err.contains(needle), "expected `{needle}` in `{err}`");
    }
}

/// Lines of plans, good and bad, for the fuzzer to combine.
const FRAGMENTS: &[&str] = &[
    "[[overlap]]",
    "[[noop]]",
    "[[edmd]]",
    "[overlap]",
    "name = \"f\"",
    "exclusive = true",
    "seed = 3",
    "l_star = 1",
    "l_star = [1, 2.5]",
    "l_star = { from = 1, to = 3 }",
    "l_star = { from = 3, to = 1 }",
    "w_star = 2",
    "w_star = { from = 0.1, to = 0.5, step = 0.1 }",
    "w_star = { step = -1 }",
    "r_star = 0.5",
    "r_star = []",
    "r_star = [[1]]",
    "r_star = { from = 1, to = 1e300, step = 1e-300 }",
    "acceptance = 0.4",
    "acceptance = 1",
    "acceptance = inf",
    "configurations = 100",
    "configurations = 1e30",
    "configurations = -1",
    "repeats = 1",
    "repeats = 0x10",
    "precision = [\"f32\", \"f64\"]",
    "precision = 3",
    "algorithms = [\"ocsi\"]",
    "algorithms = \"x\"",
    "count = 3",
    "count = 1e2",
    "duration_ms = 0",
    "fail_rate = 0.5",
    "fail_rate = [0, 2]",
    "= 1",
    "\"",
    "[",
    "x = {",
    "é = 1",
    "",
];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn parsing_never_panics(lines in proptest::collection::vec(0..FRAGMENTS.len(), 0..14), noise in "\\PC{0,12}") {
        let mut text: String = lines.iter().map(|&i| format!("{}\n", FRAGMENTS[i])).collect();
        text.push_str(&noise);
        match Plan::parse(&text, "fuzz.toml") {
            Ok(plan) => prop_assert!(!plan.jobs.is_empty()),
            Err(error) => {
                let shown = error.to_string();
                prop_assert!(!shown.contains('\n'), "{}", shown);
                prop_assert!(error.line >= 1 && error.line <= text.lines().count().max(1) + 1, "{}", shown);
            }
        }
    }
}

/// Every shape defaults to neighbour lists; the id hashes the method the point runs with, so a
/// point without `neighbours` is the NNL point, not the LL point it named before that default
/// (spheres since issue 13, ellipsoids and superquadrics since issue 29).
#[test]
fn the_default_neighbour_method_is_part_of_the_point() {
    let point = |extra: &str| {
        let plan = Plan::parse(
            &format!("[[edmd]]\nshape = \"sphere\"\nn = 256\nphi = 0.45\n{extra}"),
            "d.toml",
        )
        .expect("a valid plan");
        assert_eq!(plan.jobs.len(), 1);
        plan.jobs[0].clone()
    };
    let default = point("");
    assert_eq!(default.id(), point("neighbours = \"nnl\"\n").id());
    assert_ne!(default.id(), point("neighbours = \"ll\"\n").id());
    let JobSpec::Edmd(scene) = default else {
        panic!("an edmd job")
    };
    assert_eq!(scene.neighbours, edmd::Neighbours::Nnl);
    let ellipsoid = Plan::parse(
        "[[edmd]]\nshape = \"ellipsoid\"\nx0 = 2\nn = 256\nphi = 0.45\n",
        "e.toml",
    )
    .expect("valid");
    let JobSpec::Edmd(scene) = &ellipsoid.jobs[0] else {
        panic!("an edmd job")
    };
    assert_eq!(scene.neighbours, edmd::Neighbours::Nnl);
}

/// BLAKE3 of the sorted ids of `plan`'s EDMD points of the Figs. 7–11 campaign (Fig. 13's state
/// point, φ = 0.256, and every superquadric left out: those came later).
fn figs_7_to_11_digest(plan: &Plan) -> String {
    let mut ids: Vec<String> = plan
        .jobs
        .iter()
        .filter(|job| match job {
            JobSpec::Edmd(scene) => {
                scene.shape != edmd::ShapeKind::Superquadric && scene.phi != 0.256
            }
            _ => true,
        })
        .map(JobSpec::id)
        .collect();
    ids.sort();
    blake3::hash(ids.join("\n").as_bytes()).to_hex().to_string()
}

/// Points that existed before list-valued keys (`exponents`) could be swept keep their ids: the
/// digests below were taken on the code before that change (commit 1c41060), so a change to how
/// plans are read or ids are hashed that moved any of them would schedule done points again.
#[test]
fn ids_of_existing_edmd_plans_are_stable() {
    for (name, digest) in [
        (
            "edmd-figures.toml",
            "6fb9041f9db05a0e5e5f2bfd27b7e54fc285b7de34e8e4828216c7b561befcb4",
        ),
        (
            "edmd-figures-quick.toml",
            "4de18e1729106f407b2a670a06bc9f30e050407b2dab83c5540fb1ef7e44c734",
        ),
        (
            "fig7.toml",
            "6c9efca8a0149bb6a0e6e2cd4d5c416aea64ea8c9fbc5babb4b0bf1c35074094",
        ),
    ] {
        assert_eq!(figs_7_to_11_digest(&deploy_plan(name)), digest, "{name}");
    }
    // Spheres on lists default to Δ_NNL = 0.25 since issue 13 (faster at every N), which changes
    // what this point is, so its id changed with it (it was e6d48ee7…343b with Δ_NNL = 0.15): it
    // is now the point fig7.toml's spheres with `delta_nnl = 0.25` have always named.
    let sphere = parse("[[edmd]]\nshape = \"sphere\"\nn = 256\nphi = 0.45\n");
    assert_eq!(
        sphere.jobs[0].id(),
        "ce0e397ec2c0cf0bd3d274930430bc1ce8d9f041c9a650e2e2e6db5fe8a2bb6c"
    );
    assert_eq!(
        ids(&sphere),
        ids(&parse(
            "[[edmd]]\nshape = \"sphere\"\nn = 256\nphi = 0.45\ndelta_nnl = 0.25\n"
        ))
    );
    let ellipsoid = parse(
        "[[edmd]]\nshape = \"ellipsoid\"\nn = 256\nphi = 0.3\nx0 = 2\nneighbours = \"nnl\"\ndelta_nnl = 0.06\n",
    );
    assert_eq!(
        ellipsoid.jobs[0].id(),
        "1a434f17443be8a015059f765d663a2dc68d78ed4c3cf5196ff1157c41c6a38a"
    );
    assert!(!ellipsoid.jobs[0].canonical_json().contains("exponents"));
}

/// The spheres' new default Δ_NNL moves no other point: ellipsoids and superquadrics (on either
/// method) and spheres on cells written without `delta_nnl` keep the ids they had before it
/// (taken on the code before issue 13's change of default), as if `delta_nnl = 0.15` were written.
/// An ellipsoid that names no method is the NNL point since issue 29 (it was the LL point
/// 19e58432…61da): the ids of the first two rows.
#[test]
fn a_shape_dependent_delta_nnl_moves_only_sphere_list_points() {
    for (text, id) in [
        (
            "shape = \"ellipsoid\"\nx0 = 2\nneighbours = \"nnl\"",
            "d54083ee97e0d396f1928e6a47280e18f06fc03ccf09dcfb412a42800c520cb9",
        ),
        (
            "shape = \"ellipsoid\"\nx0 = 2",
            "d54083ee97e0d396f1928e6a47280e18f06fc03ccf09dcfb412a42800c520cb9",
        ),
        (
            "shape = \"ellipsoid\"\nx0 = 2\nneighbours = \"ll\"",
            "19e584324b2128592c9c327a63ca9a4c57ca111e1b3175b928d6561504a761da",
        ),
        (
            "shape = \"superquadric\"\nx0 = 2\nexponents = [2, 2, 4]\nneighbours = \"nnl\"",
            "fb44c8ad7152921ca0dc2e96f53488819ae66c7be9604393e2c19af209685034",
        ),
        (
            "shape = \"sphere\"\nneighbours = \"ll\"",
            "6e7f4845aad1c8740d3404821ce4af6906620e287d4729b6f54901e9e837fb04",
        ),
    ] {
        let plan = parse(&format!("[[edmd]]\nn = 256\nphi = 0.45\n{text}\n"));
        assert_eq!(plan.jobs[0].id(), id, "{text}");
        let written = parse(&format!(
            "[[edmd]]\nn = 256\nphi = 0.45\n{text}\ndelta_nnl = 0.15\n"
        ));
        assert_eq!(ids(&plan), ids(&written), "{text}");
    }
    // A sphere on lists with Δ_NNL written keeps its id whatever the default.
    let written = parse("[[edmd]]\nshape = \"sphere\"\nn = 256\nphi = 0.45\ndelta_nnl = 0.15\n");
    assert_eq!(
        written.jobs[0].id(),
        "e6d48ee732ebca6639c459d388ea2bb76b6bd5767ad781b2a69670c5aeea343b"
    );
}

fn superquadrics(exponents: &str) -> String {
    format!(
        "[[edmd]]\nshape = \"superquadric\"\nn = 64\nphi = 0.256\nx0 = [0.5, 2.0]\nexponents = {exponents}\n"
    )
}

fn exponents_of(plan: &Plan) -> Vec<[f64; 3]> {
    plan.jobs
        .iter()
        .map(|job| match job {
            JobSpec::Edmd(scene) => scene.exponents.expect("a superquadric has exponents"),
            other => panic!("an edmd job, got {other:?}"),
        })
        .collect()
}

/// `exponents = [n, m, p]` is one value of the key, not a sweep over three numbers; it is part of
/// the point, so a superquadric is never the ellipsoid of the same X0.
#[test]
fn one_list_is_one_value_of_a_list_valued_key() {
    let plan = parse(&superquadrics("[2, 2, 2]"));
    assert_eq!(
        exponents_of(&plan),
        [[2.0; 3], [2.0; 3]],
        "X0 swept, exponents one value"
    );
    assert!(
        plan.jobs[0]
            .canonical_json()
            .contains(r#""exponents":[2,2,2]"#),
        "{}",
        plan.jobs[0].canonical_json()
    );
    // Written as floats, the same point.
    assert_eq!(ids(&plan), ids(&parse(&superquadrics("[2.0, 2e0, 2]"))));
    let ellipsoids =
        parse("[[edmd]]\nshape = \"ellipsoid\"\nn = 64\nphi = 0.256\nx0 = [0.5, 2.0]\n");
    assert!(ids(&plan).is_disjoint(&ids(&ellipsoids)));
}

/// A list of lists sweeps the key: each value is one point, checked by the engine on its own.
#[test]
fn a_list_of_lists_sweeps_a_list_valued_key() {
    let text = superquadrics("[\n    [2, 2, 2],\n    [2, 2, 4],\n    [2, 2, 10],\n]");
    let plan = Plan::parse(&text, "sq.toml").unwrap_or_else(|e| panic!("{e}"));
    let mut got = exponents_of(&plan);
    got.sort_by(|a, b| a[2].total_cmp(&b[2]));
    got.dedup();
    assert_eq!(got, [[2.0, 2.0, 2.0], [2.0, 2.0, 4.0], [2.0, 2.0, 10.0]]);
    assert_eq!(
        (plan.jobs.len(), ids(&plan).len()),
        (6, 6),
        "3 exponents × 2 X0"
    );
    // Repeated lists are one point.
    let twice = parse(&superquadrics("[[2, 2, 2], [2.0, 2, 2]]"));
    assert_eq!(exponents_of(&twice), [[2.0; 3], [2.0; 3]]);
}

/// Bad list-valued input is refused with the file, the line of the offending list and the key.
#[test]
fn bad_exponents_name_the_key_and_the_line() {
    for (exponents, line, needle) in [
        ("[[2, 2, 2], [2, 2]]", 6, "length 3"),
        (
            "[\n  [2, 2, 2],\n  [2, 1.5, 2],\n]",
            8,
            "each exponent must lie in [2, ",
        ),
        ("[2, 2, \"p\"]", 6, "invalid type: string"),
        ("[2, 2, 1]", 6, "got 1"),
        ("[2, 2, nan]", 6, "finite"),
        ("[2, [2, 2, 2]]", 6, "mixes lists and single values"),
        ("[[2, 2, 2], 2]", 6, "mixes lists and single values"),
        ("[[2, 2, [2]]]", 6, "a list inside one of its lists"),
        ("4", 6, "takes a list as its value"),
        ("{ from = 2, to = 4 }", 6, "a range cannot give one"),
        ("[]", 6, "must not be an empty list"),
        ("[[]]", 6, "must not be an empty list"),
    ] {
        let text = superquadrics(exponents);
        let error = Plan::parse(&text, "sq.toml").expect_err(&text);
        let shown = error.to_string();
        assert!(!shown.contains('\n'), "one line: {shown}");
        assert_eq!(
            (error.line, error.key.as_deref()),
            (line, Some("exponents")),
            "{exponents}: {shown}"
        );
        assert!(shown.starts_with(&format!("sq.toml:{line}:")), "{shown}");
        assert!(
            shown.contains(needle),
            "{exponents}: `{needle}` not in {shown}"
        );
    }
    let ellipsoid = Plan::parse(
        "[[edmd]]\nshape = \"ellipsoid\"\nn = 64\nphi = 0.3\nexponents = [2, 2, 2]\n",
        "e.toml",
    )
    .expect_err("an ellipsoid has no exponents");
    assert!(
        ellipsoid
            .to_string()
            .starts_with("e.toml:5:13: key `exponents`: only a superquadric"),
        "{ellipsoid}"
    );
    // A key whose value is a single number still refuses lists inside its sweep.
    let nested = Plan::parse(
        "[[edmd]]\nshape = \"sphere\"\nn = 64\nphi = [[0.3]]\n",
        "s.toml",
    )
    .expect_err("a list in a sweep of numbers");
    assert!(
        nested
            .to_string()
            .starts_with("s.toml:4:8: key `phi`: a list element must be a single value"),
        "{nested}"
    );
}

/// Fig. 13's points in the EDMD plans: superquadrics [2, 2, p] at φ = 0.256, N = 512, X0 = 0.5
/// and 2, LL and NNL (p = 2 … 10 in the full plan, 2, 4, 10 in the quick one), and the hard
/// ellipsoids of the same state points.
#[test]
fn fig13_points_are_in_the_edmd_plans() {
    for (name, grid, collisions) in [
        (
            "edmd-figures.toml",
            vec![2.0, 3.0, 4.0, 6.0, 8.0, 10.0],
            20_000,
        ),
        ("edmd-figures-quick.toml", vec![2.0, 4.0, 10.0], 2_000),
    ] {
        let plan = deploy_plan(name);
        let at_fig13: Vec<&edmd::Scene> = plan
            .jobs
            .iter()
            .filter_map(|j| match j {
                JobSpec::Edmd(s) if s.phi == 0.256 => Some(s),
                _ => None,
            })
            .collect();
        let mut p: Vec<f64> = at_fig13
            .iter()
            .filter_map(|s| {
                s.exponents.map(|[n, m, p]| {
                    assert_eq!((n, m), (2.0, 2.0));
                    p
                })
            })
            .collect();
        p.sort_by(f64::total_cmp);
        p.dedup();
        assert_eq!(p, grid, "{name}");
        let ellipsoids = at_fig13
            .iter()
            .filter(|s| s.shape == edmd::ShapeKind::Ellipsoid)
            .count();
        assert_eq!(
            (at_fig13.len(), ellipsoids),
            (grid.len() * 4 + 4, 4),
            "{name}"
        );
        for s in &at_fig13 {
            assert_eq!(
                (s.n, s.collisions, s.delta_nnl, s.eps_d),
                (512, collisions, 0.06, 1e-5),
                "{name}"
            );
        }
    }
}

/// The hog experiments' plan (`scripts/hog-experiment.sh`, seed 1), as measured before visits
/// existed.
const HOG_PLAN: &str = "name = \"new-1\"\nexclusive = false\nseed = 1\n\n[[overlap]]\n\
    l_star = [1, 3, 5, 8, 11, 14, 17, 20]\nw_star = [1, 3, 5, 8, 11, 14, 17, 20]\nr_star = 5.0\n\
    acceptance = 0.4\nconfigurations = 500000\nrepeats = 3\nprecision = \"f32\"\n\
    algorithms = [\"qri\", \"qrf\", \"ocsi\", \"sse\"]\nci_target = 0.01\ntime_cap_s = 5\n";

/// Ids of that plan's corner points in the databases main wrote (/tmp/h18b-hog5/new-1.db, `SELECT
/// id FROM jobs`): `visits = 1`, or no `visits`, must give exactly these.
const MAIN_IDS: [(f64, f64, &str); 4] = [
    (
        1.0,
        1.0,
        "88e9ba72593ca5ee027c9b4f8c21660243eaf9576d73b227d632352eeac1c2e0",
    ),
    (
        20.0,
        1.0,
        "93dd72ee0cf922c4897847e9c37091e79890651f49cedea90f9375cce4982267",
    ),
    (
        20.0,
        20.0,
        "e584faecfc72e98f4dddd318583211a223012393a65aa7c2a2ca877360e5e541",
    ),
    (
        1.0,
        20.0,
        "eb5c43300dae2211d8566dc3f1b76b372b54e3a774d106e8360f36b5f33e154d",
    ),
];

fn overlap_points(plan: &Plan) -> Vec<overlap::PointSpec> {
    plan.jobs
        .iter()
        .map(|job| match job {
            JobSpec::Overlap(p) => p.clone(),
            other => panic!("not an overlap job: {other:?}"),
        })
        .collect()
}

#[test]
fn one_visit_keeps_the_ids_main_gave() {
    let plain = parse(HOG_PLAN);
    let one = parse(&format!("{HOG_PLAN}visits = 1\n"));
    assert_eq!(plain, one);
    assert_eq!(plain.jobs.len(), 64);
    for (l_star, w_star, id) in MAIN_IDS {
        let job = plain
            .jobs
            .iter()
            .find(|j| matches!(j, JobSpec::Overlap(p) if p.l_star == l_star && p.w_star == w_star))
            .expect("the corner is in the plan");
        assert_eq!(job.id(), id, "L* {l_star}, W* {w_star}");
        assert_eq!(job.pass(), 0);
    }
    assert!(!plain.jobs[0].canonical_json().contains("visit"));
}

/// `visits = 3`: three jobs per point, every point's first visit (the job a plan without
/// `visits` has), then every second, then every third; each visit its own job, id and
/// generator seed, with the pass the store leases it in; resubmitting with more visits adds
/// only the new ones.
#[test]
fn visits_expand_visit_major_with_their_own_ids() {
    let one = parse(&format!("{HOG_PLAN}visits = 1\n"));
    let three = parse(&format!("{HOG_PLAN}verdict_check = 1000\nvisits = 3\n"));
    assert_eq!(three.jobs.len(), 3 * 64);
    let points = overlap_points(&three);
    let visits: Vec<Option<u32>> = points.iter().map(|p| p.visit).collect();
    assert!(visits[..64].iter().all(|v| v.is_none()));
    assert!(visits[64..128].iter().all(|&v| v == Some(1)));
    assert!(visits[128..].iter().all(|&v| v == Some(2)));
    let passes: Vec<u32> = three.jobs.iter().map(JobSpec::pass).collect();
    assert!(passes.windows(2).all(|w| w[0] <= w[1]), "visit-major");
    // Each pass is the same sweep of points in the same order.
    for k in 0..64 {
        for visit in [64, 128] {
            let (a, b) = (&points[k], &points[visit + k]);
            assert_eq!((a.l_star, a.w_star, a.seed), (b.l_star, b.w_star, b.seed));
        }
    }
    // Only the first visit checks verdicts; timing is what visits repeat.
    assert!(points[..64].iter().all(|p| p.verdict_check == Some(1000)));
    assert!(points[64..].iter().all(|p| p.verdict_check.is_none()));
    // Distinct ids and generator seeds for every visit.
    assert_eq!(ids(&three).len(), 3 * 64);
    let seeds: BTreeSet<u64> = three.jobs.iter().map(JobSpec::generator_seed).collect();
    assert_eq!(seeds.len(), 3 * 64);
    // Going from 1 to 3 visits keeps every done job (same ids) and adds 128 new ones.
    let three_plain = parse(&format!("{HOG_PLAN}visits = 3\n"));
    assert!(ids(&one).is_subset(&ids(&three_plain)));
    assert_eq!(ids(&three_plain).difference(&ids(&one)).count(), 128);
    assert!(three.jobs[64].canonical_json().contains(r#""visit":1"#));
}

/// `[[edmd.species]]` makes a mixture point; a list of species lists sweeps them; a plan without
/// species keeps the id pinned above (the key is not serialised while unset).
#[test]
fn species_tables_make_mixture_points_and_leave_one_species_ids_alone() {
    let binary = "[[edmd]]\nn = 1000\nphi = 0.45\n\
        [[edmd.species]]\nshape = \"sphere\"\ndiameter = 1.0\nfraction = 0.5\n\
        [[edmd.species]]\nshape = \"sphere\"\ndiameter = 1.4\nfraction = 0.5\n";
    let plan = parse(binary);
    assert_eq!(plan.jobs.len(), 1);
    let JobSpec::Edmd(scene) = &plan.jobs[0] else {
        panic!("not an edmd point")
    };
    assert_eq!(scene.shape, edmd::ShapeKind::Sphere);
    let species = scene.species.as_ref().expect("species");
    assert_eq!(species[1].diameter, 1.4);
    assert!(plan.jobs[0].canonical_json().contains("species"));
    // Two species lists: two points, and the first is the table form's point.
    let swept = parse(
        "[[edmd]]\nn = 1000\nphi = 0.45\nspecies = [\n\
         [{shape = \"sphere\", diameter = 1.0, fraction = 0.5}, {shape = \"sphere\", diameter = 1.4, fraction = 0.5}],\n\
         [{shape = \"sphere\", diameter = 1.0, fraction = 0.5}, {shape = \"sphere\", diameter = 2.0, fraction = 0.5}],\n]\n",
    );
    assert_eq!(swept.jobs.len(), 2);
    assert!(ids(&swept).contains(&plan.jobs[0].id()));
    // A bad fraction names its key.
    let e = Plan::parse(
        &binary.replacen("fraction = 0.5", "fraction = 0.4", 1),
        "p.toml",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("fraction"), "{e}");
    // No species: the id pinned before the key existed.
    let sphere = parse("[[edmd]]\nshape = \"sphere\"\nn = 256\nphi = 0.45\n");
    assert_eq!(
        sphere.jobs[0].id(),
        "ce0e397ec2c0cf0bd3d274930430bc1ce8d9f041c9a650e2e2e6db5fe8a2bb6c"
    );
    assert!(!sphere.jobs[0].canonical_json().contains("species"));
}

/// Rigid species: an ellipsoid mixture and a superquadric species (its `exponents` a list inside
/// the species table) make points of the most general species' shape; the sphere mixture's id
/// does not move when its species are written with the shape keys' defaults.
#[test]
fn rigid_species_make_points_of_their_most_general_shape() {
    let rigid = "[[edmd]]\nn = 256\nphi = 0.4\n\
        [[edmd.species]]\nshape = \"sphere\"\nfraction = 0.5\n\
        [[edmd.species]]\nshape = \"superquadric\"\nx0 = 2.0\nexponents = [2.0, 2.0, 4.0]\nfraction = 0.5\n";
    let plan = parse(rigid);
    let JobSpec::Edmd(scene) = &plan.jobs[0] else {
        panic!("not an edmd point")
    };
    assert_eq!(scene.shape, edmd::ShapeKind::Superquadric);
    let species = scene.species.as_ref().expect("species");
    assert_eq!(species[1].exponents, Some([2.0, 2.0, 4.0]));
    assert_eq!(species[1].x0, 2.0);
    // A sphere species with an aspect ratio names the key.
    let e = Plan::parse(
        &rigid.replacen("shape = \"sphere\"", "shape = \"sphere\"\nx0 = 3.0", 1),
        "p.toml",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("x0"), "{e}");
    let binary = "[[edmd]]\nn = 1000\nphi = 0.45\n\
        [[edmd.species]]\nshape = \"sphere\"\ndiameter = 1.0\nfraction = 0.5\n\
        [[edmd.species]]\nshape = \"sphere\"\ndiameter = 1.4\nfraction = 0.5\n";
    let with_defaults = binary.replace("diameter = 1.4", "diameter = 1.4\nx0 = 1.0");
    assert_eq!(
        parse(binary).jobs[0].id(),
        parse(&with_defaults).jobs[0].id()
    );
}
