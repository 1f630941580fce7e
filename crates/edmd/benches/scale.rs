//! τ_c and the initial state's time against N, with the memory per particle: one process per run,
//! so that each run's peak RSS is its own.
//!
//! `cargo bench -p edmd --bench scale` runs hard spheres (φ = 0.45, NNL, the default Δ_NNL = 0.25) at
//! N = 256 … 131072 and X0 = 2 ellipsoids (φ = 0.5, NNL, Δ_NNL = 0.08) at N = 256 … 16384.
//! `SWEEP_SCALE_SPHERES` and `SWEEP_SCALE_ELLIPSOIDS` replace the lists of N (comma-separated,
//! empty for none; e.g. `SWEEP_SCALE_SPHERES=1000000` for the million), and
//! `SWEEP_SCALE_COLLISIONS_PER_PARTICLE` the length of the measured runs (default 100 for
//! spheres, 20 for ellipsoids, at least 10⁵ collisions). Every scene has the default seed (1).
//! The table goes to stdout.

use std::process::Command;

use edmd::{Neighbours, Scene, ShapeKind, run};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    // The child: one run, then its report and its peak RSS on one line.
    if let Some(at) = args.iter().position(|a| a == "--one") {
        let (shape, n, collisions) = (&args[at + 1], &args[at + 2], &args[at + 3]);
        let scene = scene(
            shape,
            n.parse().expect("N"),
            collisions.parse().expect("collisions"),
        );
        let r = run(&scene, &mut |_| {}).expect("run");
        assert_eq!(r.overlaps, 0, "overlaps at N = {n}");
        println!(
            "{} {} {} {} {}",
            r.init_s,
            r.tau_c_us,
            r.collisions,
            r.energy_drift_rel,
            peak_rss_bytes().unwrap_or(0.0)
        );
        return;
    }
    // `cargo bench` passes `--bench`; anything else that is not ours is ignored the same way.
    let exe = std::env::current_exe().expect("the bench's own path");
    let per_particle = |default: u64| {
        std::env::var("SWEEP_SCALE_COLLISIONS_PER_PARTICLE")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(default)
    };
    println!(
        "{:<10} {:>8} {:>10} {:>8} {:>10} {:>10} {:>9} {:>12}",
        "shape", "N", "collisions", "init_s", "tau_c_us", "energy", "RSS_MB", "bytes/part."
    );
    for (shape, var, default_ns, per) in [
        (
            "sphere",
            "SWEEP_SCALE_SPHERES",
            "256,2048,16384,131072",
            per_particle(100),
        ),
        (
            "ellipsoid",
            "SWEEP_SCALE_ELLIPSOIDS",
            "256,2048,16384",
            per_particle(20),
        ),
    ] {
        let ns = std::env::var(var).unwrap_or_else(|_| default_ns.to_string());
        for n in ns.split(',').filter(|s| !s.trim().is_empty()) {
            let n: u64 = n
                .trim()
                .parse()
                .unwrap_or_else(|_| panic!("{var}: not a number: {n}"));
            let collisions = (per * n).max(100_000);
            let out = Command::new(&exe)
                .args(["--one", shape, &n.to_string(), &collisions.to_string()])
                .output()
                .expect("the bench runs itself");
            assert!(
                out.status.success(),
                "{shape} N = {n}: {}",
                String::from_utf8_lossy(&out.stderr)
            );
            let line = String::from_utf8_lossy(&out.stdout);
            let f: Vec<f64> = line
                .split_whitespace()
                .filter_map(|x| x.parse().ok())
                .collect();
            let [init_s, tau_c, done, drift, rss] = f[..] else {
                panic!("{shape} N = {n}: unexpected output {line}")
            };
            println!(
                "{shape:<10} {n:>8} {done:>10} {init_s:>8.2} {tau_c:>10.3} {drift:>10.1e} {:>9.1} {:>12.0}",
                rss / 1e6,
                rss / n as f64
            );
        }
    }
}

fn scene(shape: &str, n: usize, collisions: u64) -> Scene {
    let mut s = match shape {
        "sphere" => Scene::new(ShapeKind::Sphere, n, 0.45),
        _ => {
            let mut s = Scene::new(ShapeKind::Ellipsoid, n, 0.5);
            s.x0 = 2.0;
            s.delta_nnl = 0.08;
            s
        }
    };
    s.neighbours = Neighbours::Nnl;
    s.collisions = collisions;
    s.equilibrate = collisions / 10;
    s
}

/// VmHWM of this process.
fn peak_rss_bytes() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024.0)
}
