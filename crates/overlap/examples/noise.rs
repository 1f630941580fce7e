//! The noise check's calibration: every measurement of a sweep of points, with the references
//! the check compares, one JSON line each, for `scripts/noise-calibration.sh` to run on a quiet
//! machine and beside a disturbance and to turn into the distributions in
//! `crates/overlap/src/noise.rs`.
//!
//! `cargo run --release -p overlap --example noise -- measure ROUNDS` measures, ROUNDS times over,
//! a point of each size (10⁵, 10⁶ and 10⁷ configurations) in f32 and f64, each at a few (L*, W*),
//! with one thread's calibration carried from point to point as a worker slot carries it.
//! `… -- spin` and `… -- memory` are the disturbances: a busy loop, and a loop streaming through
//! 1 GiB, forever (pin them with `taskset`).

use std::hint::black_box;

use overlap::{Algorithm, Calibration, PointSpec, Precision, measure_once};

fn measure(rounds: u32) {
    let mut calibration = Calibration::default();
    for round in 0..rounds {
        for configurations in [100_000, 1_000_000, 10_000_000] {
            for precision in [Precision::F32, Precision::F64] {
                for (l_star, w_star) in [(1.0, 1.0), (8.0, 2.0)] {
                    let spec = PointSpec {
                        l_star,
                        w_star,
                        r_star: 0.5,
                        acceptance: 0.4,
                        configurations,
                        repeats: 2,
                        precision,
                        algorithms: Algorithm::ALL.to_vec(),
                        seed: u64::from(round),
                        ci_target: None,
                        time_cap_s: None,
                        verdict_check: None,
                        visit: None,
                        plugins: Vec::new(),
                    };
                    let report = match measure_once(&spec, &calibration, &mut |_| {}) {
                        Ok(report) => report,
                        Err(error) => {
                            eprintln!("{error}");
                            std::process::exit(1);
                        }
                    };
                    let r = report.references;
                    let number = |x: Option<f64>| x.map_or("null".into(), |x| format!("{x}"));
                    println!(
                        "{{\"round\":{round},\"configurations\":{configurations},\"precision\":\"{precision}\",\
                         \"arrays_bytes\":{},\"core_share\":{},\"compute_before\":{},\"compute_after\":{},\
                         \"compute_baseline\":{},\"stream_before\":{},\"stream_after\":{},\
                         \"stream_baseline\":{},\"timed_s\":{},\"flagged\":{}}}",
                        report.arrays_bytes,
                        r.core_share,
                        r.compute_ns_before,
                        r.compute_ns_after,
                        number(r.compute_ns_baseline),
                        r.stream_ns_before,
                        r.stream_ns_after,
                        number(r.stream_ns_baseline),
                        report.timed_s,
                        r.disturbance().is_some(),
                    );
                    calibration.remember(r.compute_ns_before);
                    calibration.remember(r.compute_ns_after);
                    calibration.remember_stream(report.arrays_bytes, r.stream_ns_before);
                    calibration.remember_stream(report.arrays_bytes, r.stream_ns_after);
                }
            }
        }
    }
}

fn spin() -> ! {
    let mut x = 1u64;
    loop {
        x = black_box(x.wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(17));
    }
}

fn memory() -> ! {
    let mut buffer = vec![1u64; 1 << 27];
    loop {
        for x in buffer.iter_mut() {
            *x = black_box(x.wrapping_add(1));
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.iter().map(String::as_str).collect::<Vec<_>>()[..] {
        ["measure", rounds] => match rounds.parse() {
            Ok(rounds) => measure(rounds),
            Err(_) => eprintln!("measure ROUNDS: `{rounds}` is not a count"),
        },
        ["spin"] => spin(),
        ["memory"] => memory(),
        _ => eprintln!("usage: noise measure ROUNDS | spin | memory"),
    }
}
