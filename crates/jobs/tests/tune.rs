//! `[[tune]]` tables: one search per state point, their evaluations ordinary EDMD points.

use jobs::{JobSpec, Plan, TuneGoal};

const ISSUE_EXAMPLE: &str = r#"
[[tune]]
family = "edmd"
knob = "delta_nnl"
range = [0.02, 1.5]
goal = "min tau_c_us"
shape = "ellipsoid"
n = 256
phi = [0.3, 0.45, 0.57]
x0 = [0.5, 2.0]
neighbours = "nnl"
collisions = 20000
"#;

#[test]
fn a_tune_table_is_one_search_per_state_point() {
    let plan = Plan::parse(ISSUE_EXAMPLE, "tune.toml").unwrap();
    assert!(plan.jobs.is_empty());
    assert_eq!(plan.tunes.len(), 6);
    let ids: std::collections::BTreeSet<String> = plan.tunes.iter().map(|t| t.id()).collect();
    assert_eq!(ids.len(), 6, "each state point its own search");
    for t in &plan.tunes {
        assert_eq!(t.knob, "delta_nnl");
        assert_eq!(t.range, [0.02, 1.5]);
        assert_eq!(t.goal, TuneGoal::Min("tau_c_us".into()));
        assert_eq!(t.max_evaluations, 12);
        assert_eq!(t.template.collisions, 20000);
    }
}

/// An evaluation is the point an `[[edmd]]` table with that Δ_NNL would make (a grid's run is
/// the search's own), and the search recognises its evaluations, and only them.
#[test]
fn an_evaluation_is_the_grid_point_of_the_same_scene() {
    let plan = Plan::parse(ISSUE_EXAMPLE, "tune.toml").unwrap();
    let grid = Plan::parse(
        "[[edmd]]\nshape = \"ellipsoid\"\nn = 256\nphi = 0.3\nx0 = 0.5\nneighbours = \"nnl\"\ncollisions = 20000\ndelta_nnl = 0.1\n",
        "grid.toml",
    )
    .unwrap();
    let search = plan
        .tunes
        .iter()
        .find(|t| t.template.phi == 0.3 && t.template.x0 == 0.5)
        .unwrap();
    assert_eq!(search.evaluation(0.1, 0).id(), grid.jobs[0].id());
    let JobSpec::Edmd(scene) = search.evaluation(0.1732, 2) else {
        panic!()
    };
    assert_eq!(search.evaluates(&scene), Some((0.1732, 2)));
    let other = plan.tunes.iter().find(|t| t.template.phi == 0.45).unwrap();
    assert_eq!(other.evaluates(&scene), None, "another state point's run");
    let mut far = scene.clone();
    far.seed += 5000;
    assert_eq!(search.evaluates(&far), None, "a seed no repeat has");
    // The key the driver sorts jobs by: the same for every run of the state point (any knob
    // value, any seed), another for another state point or another knob's blank.
    let JobSpec::Edmd(grid_scene) = &grid.jobs[0] else {
        panic!()
    };
    for candidate in [&scene, &far, grid_scene] {
        assert_eq!(
            jobs::state_point_of(candidate, "delta_nnl"),
            search.state_point()
        );
    }
    assert_ne!(other.state_point(), search.state_point());
    assert_ne!(jobs::state_point_of(&scene, "eps_d"), search.state_point());
}

/// A table's searches pool their runs when they differ only in φ and X0; another N, another
/// knob, another range or another goal is another pool.
#[test]
fn the_searches_of_a_table_that_differ_in_phi_and_x0_share_a_pool() {
    let plan = Plan::parse(ISSUE_EXAMPLE, "tune.toml").unwrap();
    let pools: std::collections::BTreeSet<String> = plan.tunes.iter().map(|t| t.pool()).collect();
    assert_eq!(pools.len(), 1, "{pools:?}");
    let pool = plan.tunes[0].pool();
    for (from, to) in [
        ("n = 256", "n = 512"),
        ("range = [0.02, 1.5]", "range = [0.02, 1.0]"),
        ("goal = \"min tau_c_us\"", "goal = \"min tau_c_cpu_us\""),
        ("neighbours = \"nnl\"", "neighbours = \"nnl\"\neps_d = 1e-4"),
    ] {
        let other = Plan::parse(&ISSUE_EXAMPLE.replace(from, to), "tune.toml").unwrap();
        assert_ne!(other.tunes[0].pool(), pool, "{to}");
    }
}

#[test]
fn bad_tune_tables_are_refused_naming_the_key() {
    let body = "shape = \"ellipsoid\"\nn = 256\nphi = 0.3\n";
    for (table, key) in [
        (
            "knob = \"delta_nnl\"\nrange = [0.02, 1.5]\ngoal = \"min tau_c_us\"\n",
            "family",
        ),
        (
            "family = \"overlap\"\nknob = \"delta_nnl\"\nrange = [0.02, 1.5]\ngoal = \"min tau_c_us\"\n",
            "family",
        ),
        (
            "family = \"edmd\"\nknob = \"phi\"\nrange = [0.02, 1.5]\ngoal = \"min tau_c_us\"\n",
            "knob",
        ),
        (
            "family = \"edmd\"\nknob = \"delta_nnl\"\nrange = [1.5, 0.02]\ngoal = \"min tau_c_us\"\n",
            "range",
        ),
        (
            "family = \"edmd\"\nknob = \"delta_nnl\"\nrange = [0, 1]\ngoal = \"min tau_c_us\"\n",
            "range",
        ),
        (
            "family = \"edmd\"\nknob = \"delta_nnl\"\nrange = [0.02, 1.5]\ngoal = \"max tau_c_us\"\n",
            "goal",
        ),
        (
            "family = \"edmd\"\nknob = \"delta_nnl\"\nrange = [0.02, 1.5]\ngoal = \"min pressure_z\"\n",
            "goal",
        ),
        (
            "family = \"edmd\"\nknob = \"delta_nnl\"\nrange = [0.02, 1.5]\ngoal = \"loosest safe\"\n",
            "knob",
        ),
        (
            "family = \"edmd\"\nknob = \"eps_d\"\nrange = [1e-9, 1e-3]\ngoal = \"loosest safe\"\nmax_evaluations = 2\n",
            "max_evaluations",
        ),
        (
            "family = \"edmd\"\nknob = \"delta_nnl\"\nrange = [0.02, 1.5]\ngoal = \"min tau_c_us\"\ndelta_nnl = 0.1\n",
            "delta_nnl",
        ),
        (
            "family = \"edmd\"\nknob = \"delta_nnl\"\nrange = [0.02, 1.5]\ngoal = \"min tau_c_us\"\nwhatever = 1\n",
            "whatever",
        ),
    ] {
        let text = format!("[[tune]]\n{table}{body}");
        let e = Plan::parse(&text, "t.toml").unwrap_err();
        assert_eq!(e.key.as_deref(), Some(key), "{text}\n{e}");
        assert!(e.to_string().starts_with("t.toml:"), "{e}");
    }
}

#[test]
fn a_range_reaching_values_no_scene_can_run_is_refused_at_plan_time() {
    // ε_d must stay below the smallest semi-axis (0.397 at X0 = 2): a search up to 1 would
    // fail every evaluation above it and call them unsafe.
    let text = "[[tune]]\nfamily = \"edmd\"\nknob = \"eps_d\"\nrange = [1e-6, 1.0]\n\
                goal = \"loosest safe\"\nshape = \"ellipsoid\"\nx0 = 2.0\nn = 256\nphi = 0.3\n";
    let e = Plan::parse(text, "t.toml").unwrap_err();
    assert_eq!((e.key.as_deref(), e.line), (Some("range"), 4), "{e}");
    assert!(e.to_string().contains("eps_d = 1"), "{e}");
    assert!(e.to_string().contains("smallest semi-axis"), "{e}");
    let fine = text.replace("1.0]", "0.1]");
    assert_eq!(Plan::parse(&fine, "t.toml").unwrap().tunes.len(), 1);
}
