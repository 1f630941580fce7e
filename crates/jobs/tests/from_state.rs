//! EDMD points that start from a state file: the file's hash names the point, a missing or
//! mismatching file is refused at the plan's line, and the point runs from the state.

use std::path::PathBuf;

use jobs::{JobSpec, Plan};

/// A folder of its own under the system's temporary one, with a state of 128 spheres in it.
fn folder_with_state(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sweep-from-state-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let mut scene = edmd::Scene::new(edmd::ShapeKind::Sphere, 128, 0.4);
    scene.equilibrate = 0;
    scene.collisions = 2_000;
    let mut bytes = Vec::new();
    let mut on_state = |s: &edmd::SavedState| {
        bytes = s.to_bytes().map_err(|e| e.to_string())?;
        Ok(())
    };
    let hooks = edmd::Hooks {
        save_final: true,
        on_state: Some(&mut on_state),
        ..edmd::Hooks::default()
    };
    edmd::run_with_hooks(&scene, &mut |_| {}, hooks).expect("run");
    std::fs::write(dir.join("eq.state"), &bytes).expect("write state");
    dir
}

fn plan(extra: &str) -> String {
    format!(
        "[[edmd]]\nshape = \"sphere\"\nn = 128\nphi = 0.4\nequilibrate = 0\ncollisions = 1000\ndelta_nnl = [0.15, 0.25, 0.35]\n{extra}"
    )
}

#[test]
fn a_state_file_names_the_points_and_they_run_from_it() {
    let dir = folder_with_state("ok");
    let file = dir.join("plan.toml").display().to_string();
    let without = Plan::parse(&plan(""), &file).expect("plan");
    let with = Plan::parse(&plan("from_state = \"eq.state\"\n"), &file).expect("plan");
    assert_eq!(with.jobs.len(), 3);
    let hash = blake3::hash(&std::fs::read(dir.join("eq.state")).unwrap())
        .to_hex()
        .to_string();
    for (a, b) in without.jobs.iter().zip(&with.jobs) {
        assert_ne!(a.id(), b.id());
        assert!(!a.canonical_json().contains("from_state"));
        assert!(b.canonical_json().contains(&hash));
    }
    // Another state is another point.
    let mut bytes = std::fs::read(dir.join("eq.state")).unwrap();
    std::fs::write(dir.join("other.state"), &bytes).unwrap();
    let same = Plan::parse(&plan("from_state = \"other.state\"\n"), &file).expect("plan");
    assert_ne!(
        same.jobs[0].id(),
        with.jobs[0].id(),
        "the path is part of the point"
    );
    let JobSpec::Edmd(scene) = &with.jobs[1] else {
        panic!("an edmd point")
    };
    let records = jobs::run(&with.jobs[1], 1).expect("runs from the state");
    assert_eq!(records[0]["collisions"], 1000);
    assert!(
        scene
            .from_state
            .as_deref()
            .is_some_and(|p| p.ends_with("eq.state"))
    );
    // A state file changed after the plan was expanded is refused when the point runs.
    bytes.push(0);
    std::fs::write(dir.join("eq.state"), &bytes).unwrap();
    let err = jobs::run(&with.jobs[1], 1)
        .expect_err("changed")
        .to_string();
    assert!(err.contains("changed"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_missing_or_mismatching_state_is_refused_at_its_line() {
    let dir = folder_with_state("bad");
    let file = dir.join("plan.toml").display().to_string();
    let missing = Plan::parse(&plan("from_state = \"nope.state\"\n"), &file)
        .expect_err("missing file")
        .to_string();
    assert!(
        missing.contains(":8:") && missing.contains("key `from_state`"),
        "{missing}"
    );
    let other_n = plan("from_state = \"eq.state\"\n").replace("n = 128", "n = 100");
    let mismatch = Plan::parse(&other_n, &file)
        .expect_err("other n")
        .to_string();
    assert!(
        mismatch.contains("key `from_state`") && mismatch.contains("`n`"),
        "{mismatch}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
