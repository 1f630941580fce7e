//! What the examples share: a scene given as TOML lines on the command line.

/// The scene whose TOML lines are the program's arguments (`'shape="sphere"' n=500`), or exit 2
/// with the parse error.
pub fn scene_from_args() -> edmd::Scene {
    let src: String = std::env::args().skip(1).map(|a| a + "\n").collect();
    edmd::Scene::from_toml_str(&src).unwrap_or_else(|e| {
        eprintln!("{e}");
        std::process::exit(2);
    })
}
