//! The separating axis's ascent (`contact::separating_axis_from`) of two X0 = 2 ellipsoids near
//! contact, as a contact search waits for it: each call's pose depends on the gap of the call
//! before, so the time is the ascent's chain of square roots and divisions, not its throughput.
//!
//! `cargo bench -p edmd --bench kernels`: from the line of centres (four steps) and from a kept
//! axis (two steps), per pair.

use criterion::{Criterion, criterion_group, criterion_main};
use edmd::contact::separating_axis_from;
use edmd::ellipsoid::Ellipsoid;
use edmd::geometry::{M3, Pose, V3};
use edmd::rng::Rng;
use nalgebra::{Rotation3, Unit};

const PAIRS: usize = 256;

/// Pairs of X0 = 2 ellipsoids (semi-axes 0.8, 0.4, 0.4) oriented at random, centres 0.9–1.3
/// apart (their bounding spheres overlap), and an axis near the line of centres to start from.
fn pairs(rng: &mut Rng) -> Vec<(Pose, Pose, V3)> {
    let rotation = |rng: &mut Rng| -> M3 {
        let axis = V3::new(rng.normal(), rng.normal(), rng.normal());
        *Rotation3::from_axis_angle(&Unit::new_normalize(axis), rng.range(0.0, 6.3)).matrix()
    };
    (0..PAIRS)
        .map(|_| {
            let a = Pose {
                r: V3::zeros(),
                rot: rotation(rng),
            };
            let d = V3::new(rng.normal(), rng.normal(), rng.normal()).normalize();
            let b = Pose {
                r: d * rng.range(0.9, 1.3),
                rot: rotation(rng),
            };
            let from = (d + V3::new(rng.normal(), rng.normal(), rng.normal()) * 0.05).normalize();
            (a, b, from)
        })
        .collect()
}

fn benches(c: &mut Criterion) {
    let shape = Ellipsoid::new(0.8, 0.4, 0.4);
    let pairs = pairs(&mut Rng::new(7));
    let mut g = c.benchmark_group("separating_axis");
    for (name, warm) in [("x0_2_from_centres", false), ("x0_2_from_kept_axis", true)] {
        g.bench_function(name, |bench| {
            bench.iter(|| {
                let mut gap = 0.0;
                for (a, b, from) in &pairs {
                    // Moved by nothing a double can hold, but only once the last gap is known.
                    let mut b = *b;
                    b.r.x += gap * 1e-300;
                    gap = separating_axis_from(&shape, a, &shape, &b, warm.then_some(from)).gap;
                }
                gap
            })
        });
    }
    g.finish();
}

criterion_group!(group, benches);
criterion_main!(group);
