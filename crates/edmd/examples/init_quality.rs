//! How good an initial state is, for the users of a run (issue 29's checks): the scene given as
//! TOML lines on the command line is started, and the state its equilibration would start from
//! is measured: the nematic order S2 (the largest eigenvalue of Q = ⟨3/2 u uᵀ − 1/2 I⟩ over the
//! bodies' axes 0), the largest |ρ_k| = |Σ exp(i k·r)| / N over the first Bragg peak of the FCC
//! lattice the compression starts from (k = 2π/a (±1, ±1, 1), a the lattice cell in the box;
//! 1/√N without order), and Z over the scene's `collisions` after it (run it with
//! `equilibrate = 0` and `collisions` = 2 N for Z over the first 2 collisions per body):
//! `cargo run --release -p edmd --example init_quality -- 'shape="ellipsoid"' x0=2.0 n=4096 \
//! phi=0.5 'neighbours="nnl"' delta_nnl=0.08 equilibrate=0 collisions=8192`
//! prints `init_s S2 rho_k Z Z_err tau_c_cpu_us`.

use edmd::{FrameEvery, Hooks, run_with_hooks};
use nalgebra::{Matrix3, SymmetricEigen, Vector3};

#[path = "common/args.rs"]
mod args;

fn main() {
    let scene = args::scene_from_args();
    let mut measured: Option<(f64, f64)> = None;
    let mut first = |f: &edmd::Frame| {
        if measured.is_none() {
            measured = Some((nematic_order(f), bragg_peak(f)));
        }
        Ok(())
    };
    let hooks = Hooks {
        frame_every: FrameEvery::Collisions(u64::MAX),
        on_frame: Some(&mut first),
        ..Hooks::default()
    };
    match run_with_hooks(&scene, &mut |_| {}, hooks) {
        Ok((r, _)) => {
            let (s2, rho) = measured.unwrap_or((f64::NAN, f64::NAN));
            println!(
                "{:.3} {s2:.4} {rho:.4} {:.3} {:.3} {:.3} overlaps {}",
                r.init_s, r.pressure_z, r.pressure_z_err, r.tau_c_cpu_us, r.overlaps
            );
        }
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    }
}

/// S2: the largest eigenvalue of the Q tensor of the bodies' axes 0 (rows 0 of `rot`).
fn nematic_order(f: &edmd::Frame) -> f64 {
    let mut q = Matrix3::<f64>::zeros();
    for b in f.bodies {
        let u: Vector3<f64> = b.rot.row(0).transpose();
        q += 1.5 * u * u.transpose() - 0.5 * Matrix3::identity();
    }
    q /= f.bodies.len() as f64;
    SymmetricEigen::new(q).eigenvalues.max()
}

/// The largest |ρ_k| over the (111) peaks of the FCC lattice of ⌈(N/4)^⅓⌉³ cells in the box.
fn bragg_peak(f: &edmd::Frame) -> f64 {
    let n = f.bodies.len();
    let cells = (n as f64 / 4.0).cbrt().ceil();
    let k0 = 2.0 * std::f64::consts::PI * cells / f.box_length;
    [
        [1.0, 1.0, 1.0],
        [1.0, -1.0, 1.0],
        [-1.0, 1.0, 1.0],
        [-1.0, -1.0, 1.0],
    ]
    .iter()
    .map(|d| {
        let k = Vector3::new(d[0], d[1], d[2]) * k0;
        let (c, s) = f.bodies.iter().fold((0.0, 0.0), |(c, s), b| {
            let x = k.dot(&b.r);
            (c + x.cos(), s + x.sin())
        });
        (c * c + s * s).sqrt() / n as f64
    })
    .fold(0.0, f64::max)
}
