//! Initial configurations at a target φ: a dilute FCC lattice with random orientations,
//! compressed by hard-body Monte Carlo (uniform scaling to the closest contact, then sweeps of
//! random moves), then Maxwell–Boltzmann velocities (Sec. 4.1 melts a dilute crystal similarly).

use crate::EdmdError;
use crate::ellipsoid::Ellipsoid;
use crate::geometry::{M3, V3, round_nearest};
use crate::nnl::{Obp, overlap};
use crate::pw::contact_scale;
use crate::rigid::{Body, Inertia, orthonormalize, rotate};
use crate::rng::Rng;

/// The shape as the initialiser and the audit see it.
#[derive(Clone, Copy, Debug)]
pub enum Geom {
    Sphere { sigma: f64 },
    Ellipsoid(Ellipsoid),
}

impl Geom {
    pub fn bounding_radius(&self) -> f64 {
        match self {
            Geom::Sphere { sigma } => 0.5 * sigma,
            Geom::Ellipsoid(e) => e.s.max(),
        }
    }

    /// Factor by which both bodies must be scaled about their centres to touch (< 1: overlap).
    /// For spheres |r|/σ; for ellipsoids the Perram–Wertheim function, independent of the NR solver.
    pub fn contact_scale(&self, rot_a: &M3, rot_b: &M3, r: &V3) -> f64 {
        match self {
            Geom::Sphere { sigma } => r.norm() / sigma,
            Geom::Ellipsoid(e) => contact_scale(e, rot_a, e, rot_b, r),
        }
    }

    /// Cheap certificate that the bodies, both scaled by `k` about their centres, do not touch:
    /// their bounding spheres or their bounding boxes are disjoint.
    pub fn surely_apart(&self, rot_a: &M3, rot_b: &M3, r: &V3, k: f64) -> bool {
        if r.norm() >= 2.0 * self.bounding_radius() * k {
            return true;
        }
        match self {
            Geom::Sphere { .. } => false,
            Geom::Ellipsoid(e) => {
                let half = e.s * k;
                let a = Obp {
                    c: V3::zeros(),
                    rot: *rot_a,
                    half,
                };
                let b = Obp {
                    c: *r,
                    rot: *rot_b,
                    half,
                };
                !overlap(&a, &b, &V3::zeros())
            }
        }
    }

    fn rotates(&self) -> bool {
        matches!(self, Geom::Ellipsoid(_))
    }
}

/// Minimum-image vector in a cubic box of side `l`.
pub fn min_image(d: V3, l: f64) -> V3 {
    d.map(|x| x - l * round_nearest(x / l))
}

/// A uniformly random rotation matrix (from a random unit quaternion).
fn random_rotation(rng: &mut Rng) -> M3 {
    let q = loop {
        let q = nalgebra::Vector4::new(rng.normal(), rng.normal(), rng.normal(), rng.normal());
        if q.norm() > 1e-6 {
            break q.normalize();
        }
    };
    let uq = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
        q[0], q[1], q[2], q[3],
    ));
    uq.to_rotation_matrix().into_inner()
}

/// Separation kept between bodies by the Monte Carlo, so that the dynamics starts without contact.
const GAP: f64 = 1e-9;

/// The lattice is melted at this packing fraction (or the target, if lower): a stable fluid for
/// spheres and the elongations simulated here.
const PHI_MELT: f64 = 0.25;

/// Monte Carlo sweeps that melt the lattice: each body moves about a lattice spacing.
const MELT_SWEEPS: usize = 60;

/// Monte Carlo step sizes (displacement, rotation angle), kept near 30–50 % acceptance.
struct Steps {
    dr: f64,
    dth: f64,
}

impl Steps {
    fn adapt(&mut self, acceptance: f64, l: f64) {
        let f = if acceptance > 0.5 {
            1.2
        } else if acceptance < 0.3 {
            0.8
        } else {
            1.0
        };
        self.dr = (self.dr * f).min(0.25 * l);
        self.dth = (self.dth * f).min(1.0);
    }
}

pub struct Config {
    pub l: f64,
    pub bodies: Vec<Body>,
}

/// N bodies at packing fraction `phi` (volume π/6 each) without overlaps, at temperature 1.
pub fn initial_configuration(
    n: usize,
    phi: f64,
    geom: &Geom,
    inertia: Inertia,
    rng: &mut Rng,
) -> Result<Config, EdmdError> {
    let vp = std::f64::consts::PI / 6.0;
    let l_target = (n as f64 * vp / phi).cbrt();
    let diam = 2.0 * geom.bounding_radius();
    let nc = ((n as f64 / 4.0).cbrt().ceil() as usize).max(1);
    let basis = [
        [0.0, 0.0, 0.0],
        [0.5, 0.5, 0.0],
        [0.5, 0.0, 0.5],
        [0.0, 0.5, 0.5],
    ];
    let mut sites = Vec::with_capacity(n);
    'fill: for z in 0..nc {
        for y in 0..nc {
            for x in 0..nc {
                for b in &basis {
                    if sites.len() == n {
                        break 'fill;
                    }
                    sites.push(
                        V3::new(
                            x as f64 + b[0] + 0.25,
                            y as f64 + b[1] + 0.25,
                            z as f64 + b[2] + 0.25,
                        ) / nc as f64,
                    );
                }
            }
        }
    }
    let mut rot: Vec<M3> = (0..n)
        .map(|_| {
            if geom.rotates() {
                random_rotation(rng)
            } else {
                M3::identity()
            }
        })
        .collect();
    // The densest FCC lattice, in steps of 5 % from the target box, on which the randomly
    // oriented bodies do not overlap: the less compression is left to the Monte Carlo, the better.
    let mut l = l_target;
    let mut pos: Vec<V3> = loop {
        let pos: Vec<V3> = sites.iter().map(|s| s * l).collect();
        let clear = (0..n).all(|i| {
            ((i + 1)..n).all(|j| {
                let r = min_image(pos[j] - pos[i], l);
                geom.surely_apart(&rot[i], &rot[j], &r, 1.0)
                    || geom.contact_scale(&rot[i], &rot[j], &r) > 1.0 + GAP
            })
        });
        if clear {
            break pos;
        }
        l *= 1.05;
    };
    // The lattice is melted first, at a density where the fluid is stable and moves are cheap,
    // as in Sec. 4.1: compressed without melting, an FCC lattice stays a crystal above freezing
    // (at φ = 0.5 hard spheres then give the crystal's Z ≈ 9.5, not the fluid's 13).
    let l_melt = (n as f64 * vp / phi.min(PHI_MELT)).cbrt();
    if l < l_melt {
        let s = l_melt / l;
        l = l_melt;
        for p in pos.iter_mut() {
            *p *= s;
        }
    }
    let mut steps = Steps {
        dr: 0.05 * diam,
        dth: 0.1,
    };
    // Monte Carlo moves keep pairs at least 1 + m apart (in contact-scale units) unless they were
    // closer already: the configuration then always leaves room for a compression by ~1/(1 + m).
    let mut m = 0.05;
    for _ in 0..MELT_SWEEPS {
        let acc = sweep(&mut pos, &mut rot, l, geom, steps.dr, steps.dth, m, rng);
        steps.adapt(acc, l);
    }
    let mut rounds = 0;
    while l > l_target {
        rounds += 1;
        if rounds > 20_000 {
            return Err(EdmdError::Compression {
                reached: n as f64 * vp / l.powi(3),
                target: phi,
            });
        }
        // Largest uniform compression that keeps every pair apart: μ scales with the centre distance.
        let s_floor = (l_target / l).max(0.9);
        let mut s = s_floor;
        for i in 0..n {
            for j in (i + 1)..n {
                let r = min_image(pos[j] - pos[i], l);
                if !geom.surely_apart(&rot[i], &rot[j], &r, 1.0 / s_floor) {
                    let mu = geom.contact_scale(&rot[i], &rot[j], &r);
                    s = s.max((1.0 + GAP) / mu);
                }
            }
        }
        if s < 1.0 {
            l *= s;
            for p in pos.iter_mut() {
                *p *= s;
            }
        }
        if s > 1.0 - 0.1 * m {
            m = (m * 0.7).max(1e-4);
        }
        for _ in 0..2 {
            let acc = sweep(&mut pos, &mut rot, l, geom, steps.dr, steps.dth, m, rng);
            steps.adapt(acc, l);
        }
    }

    let kt = 1.0;
    let mut bodies: Vec<Body> = pos
        .iter()
        .zip(&rot)
        .map(|(r, rot)| {
            let v = V3::new(rng.normal(), rng.normal(), rng.normal()) * (kt * inertia.inv_m).sqrt();
            let w = if inertia.inv_i > 0.0 {
                // Spin about the symmetry axis (row 0) is never changed by smooth collisions: leave it 0.
                let s = (kt * inertia.inv_i).sqrt();
                (rot.row(1).transpose() * rng.normal() + rot.row(2).transpose() * rng.normal()) * s
            } else {
                V3::zeros()
            };
            Body {
                r: r.map(|x| x.rem_euclid(l)),
                v,
                rot: *rot,
                w,
                t: 0.0,
            }
        })
        .collect();
    let mean = bodies.iter().fold(V3::zeros(), |a, b| a + b.v) / n as f64;
    let ke: f64 = bodies
        .iter()
        .map(|b| 0.5 * (b.v - mean).norm_squared())
        .sum::<f64>()
        / inertia.inv_m;
    let scale = (1.5 * n as f64 * kt / ke).sqrt();
    for b in bodies.iter_mut() {
        b.v = (b.v - mean) * scale;
    }
    Ok(Config { l, bodies })
}

/// One Monte Carlo sweep of random displacements (and rotations); returns the acceptance ratio.
/// A move is refused if it brings a pair into contact, or closer than 1 + `margin` and closer than before.
#[allow(clippy::too_many_arguments)]
fn sweep(
    pos: &mut [V3],
    rot: &mut [M3],
    l: f64,
    geom: &Geom,
    dr: f64,
    dth: f64,
    margin: f64,
    rng: &mut Rng,
) -> f64 {
    let n = pos.len();
    let mut accepted = 0;
    for _ in 0..n {
        let i = (rng.uniform() * n as f64) as usize % n;
        let p = (pos[i] + V3::new(rng.range(-dr, dr), rng.range(-dr, dr), rng.range(-dr, dr)))
            .map(|x| x.rem_euclid(l));
        let q = if geom.rotates() {
            let axis = V3::new(rng.normal(), rng.normal(), rng.normal());
            orthonormalize(&rotate(
                &rot[i],
                &axis,
                dth * rng.uniform() / axis.norm().max(1e-300),
            ))
        } else {
            rot[i]
        };
        let ok = (0..n).all(|j| {
            if j == i {
                return true;
            }
            let r = min_image(pos[j] - p, l);
            if geom.surely_apart(&q, &rot[j], &r, 1.0 + margin) {
                return true;
            }
            let mu = geom.contact_scale(&q, &rot[j], &r);
            mu > 1.0 + GAP
                && (mu >= 1.0 + margin
                    || mu >= geom.contact_scale(&rot[i], &rot[j], &min_image(pos[j] - pos[i], l)))
        });
        if ok {
            pos[i] = p;
            rot[i] = q;
            accepted += 1;
        }
    }
    accepted as f64 / n as f64
}
