//! Runs one scene given as TOML lines on the command line and prints the report as JSON:
//! `cargo run --release -p edmd --example scene -- 'shape="sphere"' n=500 phi=0.45 collisions=1000000`

#[path = "common/args.rs"]
mod args;

fn main() {
    let scene = args::scene_from_args();
    match edmd::run(&scene, &mut |_| {}) {
        Ok(r) => println!("{}", serde_json::to_string_pretty(&r).unwrap_or_default()),
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    }
}
