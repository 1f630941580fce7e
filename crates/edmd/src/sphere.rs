//! Hard spheres: the analytic path (no Newton–Raphson, no rotation).

use crate::body::SphereBody;
use crate::geometry::V3;

#[cfg(target_arch = "x86_64")]
mod avx2;

/// Signed surface distance |r| − σ of two spheres whose centres are `r` apart.
pub fn distance(r: &V3, sigma: f64) -> f64 {
    r.norm() - sigma
}

/// Contact time of two spheres with relative position `r` = r_B − r_A and velocity `v` = v_B − v_A:
/// the smaller root of |r + v t| = σ. Returns 0 for overlapping spheres that still approach
/// (numerical overlap after a collision is thereby resolved, never amplified).
pub fn contact_time(r: &V3, v: &V3, sigma: f64) -> Option<f64> {
    let t = contact_time_or_inf(r, v, sigma * sigma);
    t.is_finite().then_some(t)
}

/// [`contact_time`] as +∞ for "never". Two coincident centres (a body against itself) give +∞.
pub fn contact_time_or_inf(r: &V3, v: &V3, sigma2: f64) -> f64 {
    contact_time_from(r.dot(v), r.norm_squared() - sigma2, v.norm_squared())
}

/// The contact time from b = r·v, c = |r|² − σ² and |v|², without data-dependent branches: whether
/// a pair approaches is a coin flip, and mispredictions would serialise the square roots and
/// divisions that the sphere path's hot loop otherwise overlaps (and vectorises) over a batch.
#[inline(always)]
pub fn contact_time_from(b: f64, c: f64, vv: f64) -> f64 {
    let disc = b * b - vv * c;
    // c / (−b + √disc) is the small root without cancellation; c ≤ 0 (overlap) gives ≤ 0, hence 0.
    let t = (c / (-b + disc.max(0.0).sqrt())).max(0.0);
    if b < 0.0 && disc >= 0.0 {
        t
    } else {
        f64::INFINITY
    }
}

/// A sphere's trajectory r + v (t − t0): one cache line, so that four neighbours' go into vector
/// registers from a contiguous batch without a gather. Its last word, which the line has room
/// for anyway, holds the sphere's radius in a mixture ([`first_contact_mixed`]); spheres of one
/// size leave it 0 and never read it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(64))]
pub struct Trajectory {
    pub r: [f64; 3],
    pub t0: f64,
    pub v: [f64; 3],
    pub radius: f64,
}

impl Trajectory {
    /// The trajectory of `body` seen through the image displacement `offset`.
    #[inline]
    pub fn of(body: &SphereBody, offset: &V3) -> Self {
        let r = body.r + offset;
        Trajectory {
            r: [r.x, r.y, r.z],
            t0: body.t,
            v: [body.v.x, body.v.y, body.v.z],
            radius: 0.0,
        }
    }
}

/// The sphere at `r` with velocity `v` at time `now`, against which trajectories are searched.
#[derive(Clone, Copy, Debug)]
pub struct Probe {
    pub r: V3,
    pub v: V3,
    pub now: f64,
    /// σ², the squared contact distance (spheres of one size).
    pub sigma2: f64,
    /// The probe's radius (mixtures, [`first_contact_mixed`]: the contact distance with a
    /// neighbour is this plus the neighbour's [`Trajectory::radius`]); unread for one size.
    pub radius: f64,
}

/// The earliest contact of `probe` with any of `neighbours` before `horizon` (time after `now`): the
/// index and the time, the first index among equal times; `None` if none comes before `horizon`.
/// Four neighbours at a time where the CPU has AVX2, with the same arithmetic in the same order as
/// the scalar loop, so that a trajectory does not depend on the machine that ran it.
pub fn first_contact(
    neighbours: &[Trajectory],
    probe: &Probe,
    horizon: f64,
) -> Option<(usize, f64)> {
    first_contact_sized::<false>(neighbours, probe, horizon)
}

/// [`first_contact`] in a mixture: the contact distance of each pair is the sum of the probe's
/// radius and the neighbour's ([`Trajectory::radius`]), (σ_i + σ_j)/2. One more addition and
/// multiplication per neighbour, in every lane; spheres of one size take [`first_contact`],
/// compiled without them.
pub fn first_contact_mixed(
    neighbours: &[Trajectory],
    probe: &Probe,
    horizon: f64,
) -> Option<(usize, f64)> {
    first_contact_sized::<true>(neighbours, probe, horizon)
}

#[inline(always)]
fn first_contact_sized<const MIXED: bool>(
    neighbours: &[Trajectory],
    probe: &Probe,
    horizon: f64,
) -> Option<(usize, f64)> {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: AVX2 is present.
        return unsafe { avx2::first_contact::<MIXED>(neighbours, probe, horizon) };
    }
    first_contact_scalar::<MIXED>(neighbours, probe, horizon)
}

/// [`first_contact`] one neighbour at a time.
fn first_contact_scalar<const MIXED: bool>(
    neighbours: &[Trajectory],
    probe: &Probe,
    mut horizon: f64,
) -> Option<(usize, f64)> {
    let mut partner = usize::MAX;
    for (k, n) in neighbours.iter().enumerate() {
        let tau = contact_time_with::<MIXED>(n, probe);
        // A select, not a branch: which candidate wins is unpredictable.
        partner = if tau < horizon { k } else { partner };
        horizon = horizon.min(tau);
    }
    (partner != usize::MAX).then_some((partner, horizon))
}

/// The contact time of `probe` with one trajectory, +∞ for none: [`contact_time_from`] with the
/// arithmetic spelled out, in the order the vector version follows.
#[inline(always)]
fn contact_time_with<const MIXED: bool>(n: &Trajectory, p: &Probe) -> f64 {
    let dt = p.now - n.t0;
    let d = [0, 1, 2].map(|k| (n.r[k] + n.v[k] * dt) - p.r[k]);
    let w = [0, 1, 2].map(|k| n.v[k] - p.v[k]);
    let b = (d[0] * w[0] + d[1] * w[1]) + d[2] * w[2];
    let sigma2 = if MIXED {
        let s = p.radius + n.radius;
        s * s
    } else {
        p.sigma2
    };
    let c = ((d[0] * d[0] + d[1] * d[1]) + d[2] * d[2]) - sigma2;
    let vv = (w[0] * w[0] + w[1] * w[1]) + w[2] * w[2];
    contact_time_from(b, c, vv)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn head_on_and_miss() {
        let r = V3::new(3.0, 0.0, 0.0);
        let v = V3::new(-1.0, 0.0, 0.0);
        assert!((contact_time(&r, &v, 1.0).unwrap() - 2.0).abs() < 1e-15);
        assert_eq!(contact_time(&r, &(-v), 1.0), None);
        let r = V3::new(3.0, 1.000001, 0.0);
        assert_eq!(contact_time(&r, &v, 1.0), None);
        let r = V3::new(3.0, 0.999999, 0.0);
        let t = contact_time(&r, &v, 1.0).unwrap();
        assert!(distance(&(r + v * t), 1.0).abs() < 1e-12);
    }

    fn trajectory(r: V3, v: V3, t0: f64) -> Trajectory {
        Trajectory {
            r: r.into(),
            t0,
            v: v.into(),
            radius: 0.0,
        }
    }

    fn probe() -> Probe {
        Probe {
            r: V3::new(0.3, -0.2, 0.1),
            v: V3::new(0.5, 0.25, -1.0),
            now: 2.0,
            sigma2: 1.0,
            radius: 0.5,
        }
    }

    /// Where the neighbour is at the probe's time, relative to the probe, and its relative velocity.
    fn relative(n: &Trajectory, p: &Probe) -> (V3, V3) {
        let v = V3::from(n.v);
        (V3::from(n.r) + v * (p.now - n.t0) - p.r, v - p.v)
    }

    /// Every SIMD path against the scalar loop, to the bit.
    fn same_on_every_path(
        neighbours: &[Trajectory],
        p: &Probe,
        horizon: f64,
    ) -> Option<(usize, f64)> {
        let scalar = first_contact_scalar::<false>(neighbours, p, horizon);
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: AVX2 is present.
            let simd = unsafe { avx2::first_contact::<false>(neighbours, p, horizon) };
            assert_eq!(simd, scalar, "{} neighbours", neighbours.len());
        }
        assert_eq!(first_contact(neighbours, p, horizon), scalar);
        scalar
    }

    /// A neighbour list as the sphere path sees it: centres 0.9-1.6 σ away (a few overlapping),
    /// extrapolated from up to 0.1 before now; every third one repeats its predecessor (equal times).
    fn neighbour_lists() -> impl Strategy<Value = Vec<Trajectory>> {
        prop::collection::vec(
            (
                prop::array::uniform3(-1.0f64..1.0),
                0.9f64..1.6,
                prop::array::uniform3(-2.0f64..2.0),
                0.0f64..0.1,
            ),
            0..24,
        )
        .prop_map(|raw| {
            let p = probe();
            let mut out: Vec<Trajectory> = Vec::new();
            for (k, (dir, dist, v, back)) in raw.into_iter().enumerate() {
                let dir = V3::from(dir);
                let dir = if dir.norm() > 1e-3 {
                    dir.normalize()
                } else {
                    V3::x()
                };
                let v = V3::from(v);
                let now = p.r + dir * dist;
                let n = trajectory(now - v * back, v, p.now - back);
                out.push(if k % 3 == 2 { out[k - 1] } else { n });
            }
            out
        })
    }

    proptest! {
        /// The earliest contact before the horizon, and the first index among equal times: the
        /// same on the SIMD path, and each time a root of |r + v t| = σ that no neighbour beats
        /// by the closed form of [`contact_time`].
        #[test]
        fn first_contact_is_the_earliest_root(neighbours in neighbour_lists(), horizon in 0.05f64..5.0) {
            let p = probe();
            let found = same_on_every_path(&neighbours, &p, horizon);
            let oracle: Vec<Option<f64>> = neighbours
                .iter()
                .map(|n| {
                    let (r, v) = relative(n, &p);
                    contact_time(&r, &v, 1.0)
                })
                .collect();
            let earliest = oracle.iter().flatten().fold(f64::INFINITY, |m, &t| m.min(t));
            let tol = 1e-9;
            match found {
                Some((k, t)) => {
                    prop_assert!(t < horizon);
                    prop_assert!(t <= earliest + tol, "{t} after the oracle's {earliest}");
                    let (r, v) = relative(&neighbours[k], &p);
                    let gap = (r + v * t).norm() - 1.0;
                    // At the contact, or overlapping already and approaching (time 0).
                    prop_assert!(gap.abs() < tol || (t == 0.0 && gap < 0.0 && r.dot(&v) < 0.0), "gap {gap} at {t}");
                    prop_assert!(neighbours[..k].iter().all(|n| contact_time_with::<false>(n, &p) > t), "an earlier index has the same time");
                }
                None => prop_assert!(earliest >= horizon - tol, "missed a contact at {earliest}"),
            }
        }
    }

    proptest! {
        /// Mixtures: each neighbour with its own radius, contact at the sum of the radii. The
        /// SIMD path equals the scalar loop to the bit, and the time found is the earliest root
        /// of |r + v t| = r_p + r_j by the closed form; with every radius equal to half the
        /// one-size σ it is the one-size answer.
        #[test]
        fn mixed_first_contact_is_the_earliest_root_of_each_pairs_distance(
            neighbours in neighbour_lists(),
            radii in prop::collection::vec(0.25f64..1.0, 24),
            probe_radius in 0.25f64..1.0,
            horizon in 0.05f64..5.0,
        ) {
            let mut p = probe();
            p.radius = probe_radius;
            let sized: Vec<Trajectory> = neighbours
                .iter()
                .zip(&radii)
                .map(|(n, &r)| Trajectory { radius: r, ..*n })
                .collect();
            let scalar = first_contact_scalar::<true>(&sized, &p, horizon);
            #[cfg(target_arch = "x86_64")]
            if std::is_x86_feature_detected!("avx2") {
                // SAFETY: AVX2 is present.
                let simd = unsafe { avx2::first_contact::<true>(&sized, &p, horizon) };
                prop_assert_eq!(simd, scalar);
            }
            prop_assert_eq!(first_contact_mixed(&sized, &p, horizon), scalar);
            let oracle = sized
                .iter()
                .map(|n| {
                    let (r, v) = relative(n, &p);
                    contact_time(&r, &v, p.radius + n.radius).unwrap_or(f64::INFINITY)
                })
                .fold(f64::INFINITY, f64::min);
            match scalar {
                Some((k, t)) => {
                    prop_assert!(t <= oracle + 1e-9 && t < horizon);
                    let (r, v) = relative(&sized[k], &p);
                    let gap = (r + v * t).norm() - (p.radius + sized[k].radius);
                    prop_assert!(gap.abs() < 1e-9 || (t == 0.0 && gap < 0.0), "gap {gap} at {t}");
                }
                None => prop_assert!(oracle >= horizon - 1e-9, "missed a contact at {oracle}"),
            }
            // Equal radii 1/2: the one-size search with σ = 1.
            let halves: Vec<Trajectory> =
                neighbours.iter().map(|n| Trajectory { radius: 0.5, ..*n }).collect();
            let mut half = probe();
            half.radius = 0.5;
            prop_assert_eq!(
                first_contact_mixed(&halves, &half, horizon),
                first_contact(&neighbours, &probe(), horizon)
            );
        }
    }

    #[test]
    fn exact_grazing_touches_and_a_hair_wider_misses() {
        let p = Probe {
            r: V3::zeros(),
            v: V3::zeros(),
            now: 0.0,
            sigma2: 1.0,
            radius: 0.5,
        };
        // Impact parameter exactly σ: b² − |v|² c = 2.25 − 2.25 = 0, contact at t = 1.5.
        let graze = trajectory(V3::new(1.5, 1.0, 0.0), V3::new(-1.0, 0.0, 0.0), 0.0);
        let miss = trajectory(
            V3::new(1.5, 1.0f64.next_up(), 0.0),
            V3::new(-1.0, 0.0, 0.0),
            0.0,
        );
        let away = trajectory(V3::new(-1.5, 0.0, 0.0), V3::new(-1.0, 0.0, 0.0), 0.0);
        let at_rest = trajectory(V3::new(0.0, 1.0, 0.0), V3::zeros(), 0.0);
        for n in 0..9 {
            let mut list = vec![away; n];
            list.push(at_rest);
            list.push(miss);
            assert_eq!(same_on_every_path(&list, &p, 10.0), None);
            list.push(graze);
            assert_eq!(same_on_every_path(&list, &p, 10.0), Some((n + 2, 1.5)));
            assert_eq!(
                same_on_every_path(&list, &p, 1.5),
                None,
                "the horizon is exclusive"
            );
        }
    }

    #[test]
    fn overlapping_and_approaching_meet_now_receding_never() {
        let p = Probe {
            r: V3::zeros(),
            v: V3::zeros(),
            now: 1.0,
            sigma2: 1.0,
            radius: 0.5,
        };
        let inside = V3::new(0.0, 0.0, 1.0 - 1e-12);
        let approaching = trajectory(inside, V3::new(0.0, 0.0, -1.0), 1.0);
        let receding = trajectory(inside, V3::new(0.0, 0.0, 1.0), 1.0);
        for list in [vec![receding, approaching], vec![receding; 5]] {
            let want = (list[1] == approaching).then_some((1, 0.0));
            assert_eq!(same_on_every_path(&list, &p, 1.0), want);
        }
    }

    #[test]
    fn the_first_of_equal_times_wins_in_any_lane() {
        let p = probe();
        let far = trajectory(
            p.r + V3::new(1.5, 0.0, 0.0),
            p.v + V3::new(1.0, 0.0, 0.0),
            p.now,
        );
        let near = trajectory(
            p.r + V3::new(0.0, 1.2, 0.0),
            p.v - V3::new(0.0, 1.0, 0.0),
            p.now,
        );
        for len in 1..=11 {
            for first in 0..len {
                let mut list = vec![far; len];
                for k in (first..len).step_by(3) {
                    list[k] = near;
                }
                let got = same_on_every_path(&list, &p, 10.0);
                assert_eq!(got.map(|g| g.0), Some(first), "{len} neighbours");
                assert!((got.unwrap().1 - 0.2).abs() < 1e-15);
            }
        }
    }
}
