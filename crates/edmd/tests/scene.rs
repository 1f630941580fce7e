//! Bad scenes are rejected with a typed error naming the key, before any work is done.

use edmd::{EdmdError, Scene, SceneError, ShapeKind, run};

fn invalid_key(src: &str) -> (&'static str, Option<usize>) {
    match Scene::from_toml_str(src) {
        Err(SceneError::Invalid { key, line, .. }) => (key, line),
        other => panic!("expected an invalid-key error for {src:?}, got {other:?}"),
    }
}

#[test]
fn phi_above_close_packing() {
    assert_eq!(
        invalid_key("shape = \"sphere\"\nn = 100\nphi = 0.75\n"),
        ("phi", Some(3))
    );
    assert_eq!(
        invalid_key("shape = \"ellipsoid\"\nx0 = 2.0\nn = 100\nphi = 0.78\n"),
        ("phi", Some(4))
    );
    // Just below close packing is accepted by validation.
    assert!(Scene::from_toml_str("shape = \"sphere\"\nn = 100\nphi = 0.74\n").is_ok());
}

#[test]
fn aspect_ratio_must_be_positive() {
    assert_eq!(
        invalid_key("shape = \"ellipsoid\"\nn = 100\nphi = 0.3\nx0 = 0.0\n").0,
        "x0"
    );
    assert_eq!(
        invalid_key("shape = \"ellipsoid\"\nn = 100\nphi = 0.3\nx0 = -2.0\n"),
        ("x0", Some(4))
    );
}

#[test]
fn too_few_particles() {
    assert_eq!(
        invalid_key("shape = \"sphere\"\nn = 1\nphi = 0.3\n"),
        ("n", Some(2))
    );
}

#[test]
fn negative_eps_d() {
    assert_eq!(
        invalid_key("shape = \"sphere\"\nn = 100\nphi = 0.3\neps_d = -1e-5\n"),
        ("eps_d", Some(4))
    );
}

#[test]
fn non_finite_values() {
    assert_eq!(
        invalid_key("shape = \"sphere\"\nn = 100\nphi = nan\n").0,
        "phi"
    );
    assert_eq!(
        invalid_key("shape = \"ellipsoid\"\nn = 100\nphi = 0.3\nx0 = inf\n").0,
        "x0"
    );
}

#[test]
fn unknown_key_and_wrong_type_name_the_line() {
    let e = Scene::from_toml_str("shape = \"sphere\"\nn = 100\nphi = 0.3\nfoo = 1\n").unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, SceneError::Parse(_)));
    assert!(msg.contains("foo") && msg.contains("line 4"), "{msg}");
    let e = Scene::from_toml_str("shape = \"sphere\"\nn = \"many\"\nphi = 0.3\n").unwrap_err();
    assert!(e.to_string().contains("line 2"), "{e}");
}

#[test]
fn superquadric_needs_exponents_in_range_and_only_it_has_them() {
    let key = |src: &str| match Scene::from_toml_str(src).unwrap_err() {
        SceneError::Invalid { key, line, .. } => (key, line),
        other => panic!("{other}"),
    };
    let head = "shape = \"superquadric\"\nn = 100\nphi = 0.3\nx0 = 2.0\n";
    assert_eq!(key(head), ("exponents", None));
    assert_eq!(
        key(&format!("{head}exponents = [2.0, 2.0, 1.5]\n")),
        ("exponents", Some(5))
    );
    assert_eq!(
        key(&format!("{head}exponents = [2.0, 2.0, 1e3]\n")),
        ("exponents", Some(5))
    );
    assert_eq!(
        key("shape = \"ellipsoid\"\nn = 100\nphi = 0.3\nexponents = [2, 2, 4]\n"),
        ("exponents", Some(4))
    );
    assert_eq!(
        key(&format!("{head}exponents = [2.0, nan, 2.0]\n")),
        ("exponents", Some(5))
    );
    let high = Scene::from_toml_str(&format!("{head}exponents = [2.0, 2.0, 10.0]\n")).unwrap();
    assert_eq!(high.superquadric().unwrap().e.as_slice(), &[2.0, 2.0, 10.0]);
    let s = Scene::from_toml_str(&format!("{head}exponents = [2, 2, 2]\n")).unwrap();
    let q = s.superquadric().unwrap();
    // Equal volume to the unit-diameter sphere, a : b : c = X0 : 1 : 1.
    assert!((q.volume() - std::f64::consts::PI / 6.0).abs() < 1e-12);
    let [a, b, c] = s.semi_axes();
    assert!((a / b - 2.0).abs() < 1e-14 && b == c);
    assert_eq!(q.e.as_slice(), &[2.0; 3]);
}

#[test]
fn run_rejects_a_bad_programmatic_scene_before_any_work() {
    let mut s = Scene::new(ShapeKind::Sphere, 100_000_000, 0.9);
    s.collisions = u64::MAX;
    let t = std::time::Instant::now();
    let e = run(&s, &mut |_| panic!("no progress expected")).unwrap_err();
    assert!(
        matches!(e, EdmdError::Scene(SceneError::Invalid { key: "phi", .. })),
        "{e}"
    );
    // Any work on 10⁸ bodies (their allocation alone) takes seconds; a second leaves room for a
    // loaded CI machine that preempts the test for a few time slices.
    assert!(t.elapsed().as_millis() < 1000, "{:?}", t.elapsed());
}

#[test]
fn scene_round_trips_through_toml() {
    let s = Scene::from_toml_str(
        "shape = \"ellipsoid\"\nn = 64\nphi = 0.3\nx0 = 0.5\nneighbours = \"nnl\"\n",
    )
    .unwrap();
    let text = toml::to_string(&s).unwrap();
    assert_eq!(Scene::from_toml_str(&text).unwrap(), s);
}
