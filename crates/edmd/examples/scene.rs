//! Runs one scene given as TOML lines on the command line and prints the report as JSON:
//! `cargo run --release -p edmd --example scene -- 'shape="sphere"' n=500 phi=0.45 collisions=1000000`

fn main() {
    let src: String = std::env::args().skip(1).map(|a| a + "\n").collect();
    let scene = match edmd::Scene::from_toml_str(&src) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
    };
    match edmd::run(&scene, &mut |_| {}) {
        Ok(r) => println!("{}", serde_json::to_string_pretty(&r).unwrap_or_default()),
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    }
}
