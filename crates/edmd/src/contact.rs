//! Contact time of two moving bodies (Sec. 2.4): bounding-sphere bracketing, stepping with the
//! overestimate ḋ_max (Eqs. 32, 39), quadratic interpolation and Brent's method for grazing
//! encounters, and Newton–Raphson on Eqs. (30)–(31) for the exact time and point.

use crate::distance::{
    Bordered, Distance, Guess, SolverStats, Tolerances, distance, elongated, multipliers_guess,
};
use crate::ellipsoid::lab_matrix;
use crate::geometry::{M3, Placed, Pose, Surface, V3};
use crate::pw;
use crate::rigid::{
    Body, Flight, GapSide, Towards, ddot_max, gap_closing_rates, gap_safe_time,
    gap_safe_time_towards, support_acceleration_bound,
};
use crate::support_distance::{Certified, certify, support_point_lab};

/// Everything the contact search needs besides the solver tolerances.
#[derive(Clone, Copy, Debug)]
pub struct ContactParams {
    /// ε_d of Eq. (39).
    pub eps_d: f64,
    /// Absolute accuracy of Brent's minimisation of d(t), in units of length.
    pub brent_tol: f64,
    pub tol: Tolerances,
}

/// A predicted collision: time after the bodies' common current time, contact point, unit normal
/// pointing from A to B.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f64,
    pub xc: V3,
    pub n: V3,
}

/// Steps allowed in one search before it is abandoned as a solver failure.
const MAX_STEPS: u32 = 1_000_000;

/// Halvings of the first step from a contact the bodies are leaving before the search gives up:
/// 2⁻⁶⁰ ε_d/ḋ_max is far below any time the distance solver resolves.
const MAX_PARTING_HALVINGS: i32 = 60;

/// First contact of A and B within `horizon` after their common current time (both bodies
/// must be at the same time; B's position already carries the periodic image shift).
///
/// While the bodies are far apart (a separating-axis gap above [`FAR_GAP`]), the search steps by
/// the contact-free times of [`gap_safe_time`] from the cheap [`separating_axis`] gap; Newton–Raphson
/// distances (Eq. 9) and the stepping of Eq. (39) take over near contact.
pub fn predict<S: Surface>(
    sa: &S,
    a: &Body,
    sb: &S,
    b: &Body,
    horizon: f64,
    p: &ContactParams,
    stats: &mut SolverStats,
) -> Option<Hit> {
    predict_from(sa, a, sb, b, horizon, None, p, stats)
}

/// What the caller of [`predict_from`] may know already of A and B as they are now.
#[derive(Clone, Copy, Debug)]
pub enum Known {
    /// Their [`separating_axis`] gap and its safe time ([`AxisGap::safe_time`]): the search's
    /// first step.
    Gap(AxisGap, f64),
    /// They touch, at these offsets from their centres (lab frame): the contact just resolved,
    /// which they leave. The search starts from it instead of a distance at their contact.
    Contact { offset_a: V3, offset_b: V3 },
}

/// [`predict`], given what the caller knows of A and B as they are now, where their bounding
/// spheres overlap now.
#[allow(clippy::too_many_arguments)]
pub fn predict_from<S: Surface>(
    sa: &S,
    a: &Body,
    sb: &S,
    b: &Body,
    horizon: f64,
    known: Option<Known>,
    p: &ContactParams,
    stats: &mut SolverStats,
) -> Option<Hit> {
    stats.searches += 1;
    let (la, lb) = (sa.bounding_radius(), sb.bounding_radius());
    let (t1, t2) = bounding_sphere_window(&(b.r - a.r), &(b.v - a.v), la + lb)?;
    let t2 = t2.min(horizon);
    if t1 > t2 {
        return None;
    }
    let ddmax = ddot_max(a, b, la, lb);
    if ddmax == 0.0 {
        return None;
    }
    let mut search = Search::new(sa, a, sb, b, p, stats);
    let growth = FarGrowth::of(sa, sb);
    let (mut t, mut cur) = match known {
        Some(Known::Contact { offset_a, offset_b }) if t1 == 0.0 => {
            let (pa, pb) = (a.pose_after(0.0), b.pose_after(0.0));
            let (xa, xb) = (pa.r + offset_a, pb.r + offset_b);
            let (alpha, beta) = multipliers_guess(sa, &pa, sb, &pb, &xa, &xb);
            let d = Distance {
                d: 0.0,
                xa,
                xb,
                alpha,
                beta,
            };
            (0.0, Some(d))
        }
        _ => {
            let now = match known {
                Some(Known::Gap(gap, safe)) => Some((gap, safe)),
                _ => None,
            };
            let (t, near) = approach(&mut search, t1, t2, now)?;
            // Newton–Raphson on Eqs. (30) straight from the support points the approach ended
            // at, without the distance there: the support gap along their axis bounds the
            // distance from below as the distance itself does, so the proof that the contact
            // comes first holds as it stands. Measured at X0 = 2, φ = 0.5, N 256, NNL: 98 % of
            // these tries find the contact, distances per collision fall from 2.06 to 0.34, and
            // a collision takes 5.8 % fewer instructions (MEASUREMENTS.md, "Newton from the
            // approach's support points"). The contact may lie anywhere before the horizon: the
            // gap's linear estimate falls short of it more often than the distance's does.
            // Flat faces are left to the distance: their support points run across a face as
            // the axis turns, and Newton from there failed often enough to cost superquadrics
            // 3.3 % (p = 10) and 2.5 % (p = 4) more instructions.
            if near.d > 0.0 && !growth.flat() {
                let slope = search.slope(t, &near);
                if slope < 0.0
                    && let Some(h) = search.direct(t, &near, slope, t2)
                {
                    return Some(h);
                }
            }
            (t, search.dist(t, Some(&near)))
        }
    };
    if let Some(d0) = cur
        && d0.d <= 0.0
        && approaching(sa, a, b, &d0, t)
    {
        // Touching or overlapping (by rounding) and still approaching: collide at once.
        return Some(search.hit_from_distance(&d0, t));
    }
    // The last successful evaluation: a failed one in between must not hide a sign change.
    let mut last = cur.map(|d| (t, d));
    let mut failures = 0;
    // Step multiplier for the far regime (see below); 1 is the plain step of Eq. (39).
    let mut k: f64 = 1.0;
    // A contact found by a jump but not proved the first, kept on flat faces (see `Candidate`).
    let keep_candidates = growth.flat();
    let mut candidate: Option<Candidate> = None;
    // The secant jump, tried once per search, proves its contact the first with a curvature
    // bound, or on flat faces with their support modulus ([`Search::first_contact_after`]).
    let mut secant = true;
    if secant
        && let Some(c) = cur
        && c.d > p.eps_d
    {
        // The speculative jump (below) made at once, from the first distance and its exact slope
        // ḋ instead of a secant through two: measured at X0 = 2, φ = 0.5, it finds 97 % of the
        // contacts it tries, and saves the step a secant needs. Tried once a search, either way.
        // Before it, Newton–Raphson on Eqs. (30) straight from d/|ḋ| ([`Search::direct`]): at
        // X0 = 2, φ = 0.5 it converges in 99 % of its tries and its contact is proved the first
        // in 96 % at least, in as many iterations as from the jump's bracket, without the
        // jump's distance.
        secant = false;
        let slope = search.slope(t, &c);
        let ts = t + 1.5 * c.d / -slope;
        if slope < 0.0 && ts <= t2 {
            if let Some(h) = search.direct(t, &c, slope, ts) {
                return Some(h);
            }
            match search.speculate(t, &c, ts) {
                Jump::Hit(h) => return Some(h),
                Jump::Unproved(c) if keep_candidates => candidate = c,
                _ => {}
            }
        }
    }
    // Halvings of the first step from a contact the bodies are leaving (see the parting arm below).
    let mut parting_halvings = 0;
    for _ in 0..MAX_STEPS {
        if let Some(c) = candidate
            && t >= c.free_after
        {
            return Some(c.hit);
        }
        if t > t2 {
            return None;
        }
        let far = matches!(cur, Some(c) if c.d > p.eps_d);
        // Whether [t, t + dt] is proved free of contact, or only no longer than ε_d/ḋ_max.
        let mut proved = far;
        // The step, and how long after t no contact is possible (0 where unknown).
        let (dt, safe_ahead) = match cur {
            Some(c) => {
                // No contact is possible within `safe` of t: as rigorous as the d/ḋ_max of
                // Eq. (39), usually longer, and infinite once the gap can no longer close.
                let safe = search.safe_time(t, &c);
                if let Some(c) = candidate
                    && t + safe >= c.free_after
                {
                    return Some(c.hit);
                }
                if t + safe > t2 {
                    return None;
                }
                if far {
                    ((k * safe).min(t2 - t), safe)
                } else {
                    let step = p.eps_d / ddmax * 0.5f64.powi(parting_halvings);
                    proved = safe >= step;
                    (safe.max(step), safe)
                }
            }
            None => (p.eps_d / ddmax, 0.0),
        };
        let tn = t + dt;
        let failures_before = search.stats.failures;
        let next = search.dist(tn, last.as_ref().map(|l| &l.1));
        if far && k > 1.0 {
            // Two-sided bound (not in the paper): the gap cannot close within [t, tn] if the forward
            // bound from t and the backward bound from tn leave no common zero. Uncertified: redo it
            // with the plain step.
            // The forward interval from t is `safe_ahead`, already computed for the step.
            let certified =
                matches!(next, Some(n) if search.covered_backwards(safe_ahead, t, &n, dt));
            if !certified {
                // A long step may land deep in an overlap, where no distance exists: not a failure.
                search.stats.failures = failures_before;
                k = 1.0;
                continue;
            }
        }
        if far {
            k = (k * growth.factor).min(growth.max);
        }
        // Every step is either proved contact-free or no longer than ε_d/ḋ_max, so the first
        // sign change brackets the first contact. A sign change over a longer, uncertified step
        // proves a contact but not the first one (the bodies may touch, pass through each other
        // and part within it): a secant jump once refined such a bracket to the parting of a
        // p = 4 pair and missed the contact. The secant below is used only when what it found
        // is proved to be the first contact.
        match (last, next) {
            // The step starts at a contact the bodies are leaving (the collision just processed:
            // an approaching one returned above) and ends in an overlap. The bracket holds two
            // zeros, the parting one at its start and the contact sought: refined, it would give
            // the parting one, a collision of separating bodies at once, predicted anew for ever.
            // Halve the step until it ends apart (d grows from t, so it will): the contact
            // sought then lies beyond, bracketed from a positive distance. Only where the
            // bodies part at t and approach at tn: a contact reached by a step (d rounded to
            // ±0 at t, approaching) is refined below, and an overlap the bodies are still
            // leaving at tn (a slow parting within a step of a tight ε_d) holds no second zero.
            // Halving either of those made a Zeno sequence of steps at ε_d = 1e-7.
            (Some((tl, l)), Some(n))
                if tl == t
                    && l.d <= 0.0
                    && n.d < 0.0
                    && !approaching(sa, a, b, &l, t)
                    && approaching(sa, a, b, &n, tn) =>
            {
                parting_halvings += 1;
                if parting_halvings > MAX_PARTING_HALVINGS {
                    search.stats.failures += 1;
                    search.stats.failed = Some("contact time (bodies at contact do not part)");
                    return None;
                }
                continue;
            }
            (Some((tl, l)), Some(n)) if l.d >= 0.0 && n.d < 0.0 => {
                return search.refine(tl, &l, tn, &n);
            }
            // A grazing contact can hide only inside a step that was not proved free of one.
            (Some((tl, l)), Some(n))
                if tl == t
                    && !proved
                    && l.d > 0.0
                    && n.d > 0.0
                    && l.d < p.eps_d
                    && n.d < p.eps_d =>
            {
                if let Some(h) = search.grazing(t, &l, tn, &n) {
                    return Some(h);
                }
            }
            (Some((tl, l)), Some(n)) if tl == t && n.d > p.eps_d && n.d < l.d && secant => {
                // Speculative secant step (not in the paper): the Eq. (39) steps approach a contact
                // geometrically at the rate ḋ/ḋ_max, slow when rotation inflates ḋ_max. Aim 50 %
                // past the secant estimate of the crossing; a contact refined from there is
                // returned only if [`Search::first_contact_after`] proves nothing comes before
                // it, else the stepping goes on as if the jump had not been tried (once a search).
                let ts = tn + 1.5 * n.d * (tn - t) / (l.d - n.d);
                if ts <= t2 {
                    match search.speculate(tn, &n, ts) {
                        Jump::Hit(h) => return Some(h),
                        Jump::Unproved(c) => {
                            secant = false;
                            if keep_candidates {
                                candidate = c;
                            }
                        }
                        Jump::Short => {}
                    }
                }
            }
            (_, None) => {
                failures += 1;
                if failures > 50 {
                    // A contact may lie behind the unresolved distances: never skip it silently.
                    search.stats.failures += 1;
                    search.stats.failed = Some("contact time (distance unresolved 50 times)");
                    return None;
                }
            }
            _ => {}
        }
        t = tn;
        cur = next;
        if let Some(n) = next {
            last = Some((tn, n));
        }
        parting_halvings = 0;
    }
    search.stats.failures += 1;
    search.stats.failed = Some("contact time (Eq. 39 stepping)");
    None
}

/// How the far regime's step multiplier k of [`predict_from`] grows after each far step: its
/// steps of k times the contact-free time are taken when the two-sided test proves them, and one
/// that fails costs a distance for nothing.
#[derive(Clone, Copy, Debug)]
struct FarGrowth {
    factor: f64,
    max: f64,
}

impl FarGrowth {
    /// Curved bodies: ×1.5 a step up to 4, where their safe times grow superlinearly with the gap.
    const CURVED: FarGrowth = FarGrowth {
        factor: 1.5,
        max: 4.0,
    };

    /// Flat faces (a superquadric exponent above 2): their support modulus is a power
    /// e/(e − 1) of the turn, nearly linear at e = 10, so the contact-free intervals forwards
    /// from t and backwards from t + k·safe are each about d/(L|ω × n|): together they cover
    /// at most about 2 safe times, less as the gap closes. The curved schedule's k = 2.25 and
    /// beyond failed 44 % of its tries at p = 10 (X0 = 2, φ = 0.256, N 512, NNL: 97,000 of
    /// 500,000 distances wasted); k = 1.75 from the second far step failed 1.5 %. Measured
    /// (distances per collision): k = 1.5 37.1, 1.6 36.2, 1.7 34.5, 1.75 34.4, 1.8 34.6,
    /// 1.9 34.3, 2 (reached ×1.25) 37.3, the curved schedule 50.4.
    const FLAT: FarGrowth = FarGrowth {
        factor: 1.75,
        max: 1.75,
    };

    fn flat(&self) -> bool {
        self.max == Self::FLAT.max
    }

    fn of<S: Surface>(sa: &S, sb: &S) -> Self {
        if sa.max_curvature_radius().is_finite() && sb.max_curvature_radius().is_finite() {
            Self::CURVED
        } else {
            Self::FLAT
        }
    }
}

/// The separating-axis stepping of [`predict_from`] from `t1`: the time the bodies are first
/// within [`FAR_GAP`] of each other, with their support points there, or `None` if that cannot
/// happen before `t2`. `now` is the gap at the present, if known.
fn approach<S: Surface>(
    search: &mut Search<'_, S>,
    t1: f64,
    t2: f64,
    mut now: Option<(AxisGap, f64)>,
) -> Option<(f64, Distance)> {
    let (sa, a, sb, b) = (search.sa, search.a, search.sb, search.b);
    let mut t = t1;
    let mut steps = 0;
    // The axis of the step before: the next step's ascent starts there.
    let mut axis: Option<V3> = None;
    loop {
        steps += 1;
        if steps > MAX_STEPS {
            search.stats.failures += 1;
            search.stats.failed = Some("contact time (separating-axis stepping)");
            return None;
        }
        let (pa, pb) = (search.fa.pose_after(t), search.fb.pose_after(t));
        let (gap, safe) = match now.take() {
            Some(known) if t == 0.0 => known,
            _ => {
                let gap = separating_axis_from(sa, &pa, sb, &pb, axis.as_ref());
                (gap, gap.safe_time(sa, a, sb, b))
            }
        };
        axis = Some(gap.n);
        // A small gap may still prove the horizon free (a pair parting, a close horizon): then
        // no distance is needed at all.
        if t + safe > t2 {
            return None;
        }
        if gap.gap <= FAR_GAP {
            // The support points are nearly the closest points: Newton–Raphson starts there.
            return Some((t, gap.support_start(sa, &pa, sb, &pb)));
        }
        t += safe;
    }
}

/// Below this separating-axis gap (in units of σ) the contact search switches from the cheap
/// bounds to Newton–Raphson distances. Only a matter of speed: both ways are rigorous. 0.001
/// rather than 0.01: 10.7 instead of 11.7 distances per collision for ellipsoids X0 = 2,
/// φ = 0.5, NNL, and fewer for every superquadric of the hard-case suite's short runs.
pub const FAR_GAP: f64 = 0.001;

/// The best separating axis found between two placed bodies: the support gap along `n` (a lower
/// bound on their distance), and the offsets of the support points from the centres (lab frame).
#[derive(Clone, Copy, Debug)]
pub struct AxisGap {
    pub gap: f64,
    pub n: V3,
    pub offset_a: V3,
    pub offset_b: V3,
    /// The orientations the gap was found at.
    pub rot_a: M3,
    pub rot_b: M3,
    /// What the support points' solves left for the moduli there
    /// ([`Surface::support_point_kept`]; NaN for nothing).
    pub kept: [f64; 2],
}

/// The support gap g(n) = n·(r_B − r_A) − h_A(n) − h_B(−n) along any direction n bounds the
/// distance from below (a separating axis); its maximum over n is the distance. A few steps of
/// gradient ascent on the unit sphere from the line of centres come close: ∇g = x_B − x_A, the
/// vector between the support points, and the step is damped by the largest radii of curvature,
/// which bound how fast the support points move with n. No Newton–Raphson, no failure.
/// Bodies of aspect ratio above 5 take `elongated_axis` instead.
pub fn separating_axis<S: Surface>(sa: &S, pa: &Pose, sb: &S, pb: &Pose) -> AxisGap {
    separating_axis_from(sa, pa, sb, pb, None)
}

/// [`separating_axis`] started from the unit axis `from` (lab frame, from A to B) where one is
/// known: an axis from a moment before is close to the best one, and `WARM_AXIS_STEPS` steps
/// take it the rest of the way.
pub fn separating_axis_from<S: Surface>(
    sa: &S,
    pa: &Pose,
    sb: &S,
    pb: &Pose,
    from: Option<&V3>,
) -> AxisGap {
    if elongated(sa) || elongated(sb) {
        return elongated_axis(sa, pa, sb, pb);
    }
    let mut ascent = AxisAscent::start(sa, pa, sb, pb, from);
    ascent.finish(sa, sb);
    ascent.gap()
}

/// The ascent steps of [`separating_axis`] from the line of centres, and from a known axis.
const AXIS_STEPS: usize = 4;
const WARM_AXIS_STEPS: usize = 2;

/// The gradient ascent of [`separating_axis`], stepped on demand: the engine orders and rules out
/// most candidates on the gap of the first step, and takes the others to the whole ascent.
#[derive(Clone, Copy, Debug)]
struct AxisAscent {
    /// B's axes seen from A's body frame, where the ascent works.
    b_to_a: M3,
    /// The line of centres in A's frame.
    r: V3,
    damping: f64,
    /// The next direction to try, in A's frame: a unit vector after [`AxisAscent::step`], of
    /// any length after [`AxisAscent::step_scale_free`].
    n: V3,
    /// The largest gap so far, its direction and support offsets (A's frame).
    best: (f64, V3, V3, V3),
    /// What the best step's support points left for their moduli.
    kept: [f64; 2],
    rot_a: M3,
    rot_b: M3,
    steps: usize,
    /// The steps of a whole ascent: fewer from a known axis than from the line of centres.
    full: usize,
}

impl AxisAscent {
    /// Before the first step, from the axis `from` (lab frame, from A to B) or else from the line
    /// of centres. Inlined, the poses come in registers: stored by the caller and loaded here in
    /// other widths straight after, they waited for the stores to reach the cache.
    #[inline(always)]
    fn start<S: Surface>(sa: &S, pa: &Pose, sb: &S, pb: &Pose, from: Option<&V3>) -> Self {
        let r = pa.rot * (pb.r - pa.r);
        let (n, full) = match from {
            Some(n) => (pa.rot * n, WARM_AXIS_STEPS),
            None => (r.normalize(), AXIS_STEPS),
        };
        AxisAscent {
            b_to_a: pa.rot * pb.rot.transpose(),
            r,
            // Only the step length of the search: any damping leaves every gap a rigorous lower
            // bound. A flat face has no largest radius of curvature; its bounding radius stands in.
            damping: 1.0 / (search_radius(sa) + search_radius(sb)),
            n,
            best: (f64::NEG_INFINITY, n, V3::zeros(), V3::zeros()),
            kept: [f64::NAN; 2],
            rot_a: pa.rot,
            rot_b: pb.rot,
            steps: 0,
            full,
        }
    }

    /// Steps until the ascent has taken all its steps.
    fn finish<S: Surface>(&mut self, sa: &S, sb: &S) {
        self.step_to(sa, sb, self.full);
    }

    /// Steps until `steps` have been taken in all.
    fn step_to<S: Surface>(&mut self, sa: &S, sb: &S, steps: usize) {
        while self.steps < steps {
            if S::SCALE_FREE_SUPPORT {
                self.step_scale_free(sa, sb);
            } else {
                self.step(sa, sb);
            }
            self.steps += 1;
        }
    }

    /// One step: the support points along the unit direction `n`, the gap along it, and the
    /// next direction n + (x_B − x_A − n g) κ, normalised (κ the damping).
    #[inline(always)]
    fn step<S: Surface>(&mut self, sa: &S, sb: &S) {
        let n = self.n;
        let (offset_a, kept_a) = sa.support_point_kept(&n);
        let (offset_b, kept_b) = sb.support_point_kept(&-(self.b_to_a.tr_mul(&n)));
        let offset_b = self.b_to_a * offset_b;
        let between = self.r + offset_b - offset_a;
        let gap = n.dot(&between);
        if gap > self.best.0 {
            self.best = (gap, n, offset_a, offset_b);
            self.kept = [kept_a, kept_b];
        }
        self.n = (n + (between - n * gap) * self.damping).normalize();
    }

    /// [`AxisAscent::step`] from the direction m that `n` holds, of any length, where the support
    /// point along m is p/k ([`Surface::support_point_scaled`]): the step is the same, multiplied
    /// through by |m|² k_A k_B, so that the next direction waits on no division. With x_A =
    /// p_A/k_A, x_B = p_B/k_B, n = m/|m| and B = (x_B − x_A + r) k_A k_B, the gap is
    /// g = m·B / (|m| k_A k_B), and the next direction n + (x_B − x_A − n g) κ is
    /// (m (|m| k_A k_B − κ m·B) + κ |m|² B) / (|m|² k_A k_B), whose one division runs beside the
    /// product m·B. Each gap is still taken along a unit direction, and bounds the distance.
    /// X0 = 2, φ 0.5, N 256: the ascent's share of the time fell from 7.2–7.9 % to 4.4–6.1 %
    /// (`perf`, MEASUREMENTS.md).
    #[inline(always)]
    fn step_scale_free<S: Surface>(&mut self, sa: &S, sb: &S) {
        let m = self.n;
        let (pa, ka) = sa.support_point_scaled(&m);
        let (pb, kb) = sb.support_point_scaled(&-(self.b_to_a.tr_mul(&m)));
        let pb = self.b_to_a * pb;
        let k = ka * kb;
        let mm = m.norm_squared();
        let len = mm.sqrt();
        let inv = 1.0 / (mm * k);
        let between = self.r * k + pb * ka - pa * kb;
        let dot = m.dot(&between);
        let gap = dot * len * inv;
        if gap > self.best.0 {
            // 1/k = |m|² inv, 1/|m|² = k inv.
            let unit_k = mm * inv;
            self.best = (
                gap,
                m * (len * k * inv),
                pa * (kb * unit_k),
                pb * (ka * unit_k),
            );
            self.kept = [f64::NAN; 2];
        }
        self.n = (m * (len * k - self.damping * dot) + between * (self.damping * mm)) * inv;
    }

    /// The direction the next step would try, in the lab frame: a unit vector after unscaled
    /// steps, else one of about unit length, which the engine keeps ([`crate::axes`]) and
    /// normalises when it starts from it.
    fn next_axis(&self) -> V3 {
        self.rot_a.tr_mul(&self.n)
    }

    /// The best gap so far, in the lab frame.
    fn gap(&self) -> AxisGap {
        let to_lab = self.rot_a.transpose();
        AxisGap {
            gap: self.best.0,
            n: to_lab * self.best.1,
            offset_a: to_lab * self.best.2,
            offset_b: to_lab * self.best.3,
            rot_a: self.rot_a,
            rot_b: self.rot_b,
            kept: self.kept,
        }
    }
}

/// What [`quick_bound`] finds: times after the present.
pub struct QuickBound {
    pub lower: f64,
    pub estimate: f64,
    /// The separating-axis gap of the bodies as they are and its safe time, for the contact
    /// search to start from ([`Known::Gap`]); `None` where the bound was not worth the whole
    /// ascent, or is the contact time (spheres).
    pub now: Option<(AxisGap, f64)>,
    /// Where the pair's next bound should start its ascent (an axis of about unit length from A
    /// towards B, lab frame, normalised where used): the direction this one would have tried
    /// next.
    pub axis: Option<V3>,
}

/// A lower bound on the contact time of A and B (at their common present) from the bodies that
/// hold them ([`Surface::enclosing_support`]) along the fixed unit axis `n` from A to B, closing
/// at most at [`gap_closing_rates`]: the enclosing bodies' gap along n is at most the bodies' own
/// support gap, which closes no faster than that (the linear bound of [`gap_safe_time`]). 0 where
/// the enclosing bodies meet along n, +∞ where the gap does not close. No support point is
/// solved: it rules a candidate out in tens of instructions where [`quick_bound`]'s first step
/// solves a superquadric's support points.
pub fn enclosing_bound<S: Surface>(sa: &S, a: &Body, sb: &S, b: &Body, n: &V3) -> f64 {
    let gap = (b.r - a.r).dot(n)
        - sa.enclosing_support(&(a.rot * n))
        - sb.enclosing_support(&(b.rot * -n));
    if gap.is_nan() || gap <= 0.0 {
        return 0.0;
    }
    let (closing, _) = gap_closing_rates(a, b, sa.bounding_radius(), sb.bounding_radius(), n);
    if closing > 0.0 {
        gap / closing
    } else {
        f64::INFINITY
    }
}

/// Without any solver, a lower bound on the contact time of A and B (at their common present,
/// bounding spheres overlapping) from a [`separating_axis`] gap, and an estimate of it to order
/// searches by. The ascent starts from `start` (a unit axis from A towards B: the one the pair's
/// last bound found) or else from the line of centres. A bound at or beyond `horizon` needs no
/// tighter one: there the first step of the ascent is enough. Measured at X0 = 2, φ = 0.5, NNL:
/// the engine's contact searches are the same as with the whole ascent for every candidate, at
/// 8 % less τ_c. `first` is the bound of the first step where the caller has it already (the
/// four lanes of [`crate::first_step`], which found it short of the horizon): the whole ascent
/// is then taken at once.
pub fn quick_bound<S: Surface>(
    sa: &S,
    a: &Body,
    sb: &S,
    b: &Body,
    horizon: f64,
    start: Option<&V3>,
    first: Option<f64>,
) -> QuickBound {
    if elongated(sa) || elongated(sb) {
        // Needles and plates: the ascent stalls near the line of centres, Gilbert's axis does not.
        let gap = elongated_axis(sa, &a.pose_after(0.0), sb, &b.pose_after(0.0));
        let lower = gap.safe_time(sa, a, sb, b);
        return QuickBound {
            lower,
            estimate: gap.closing_estimate(a, b).max(lower),
            now: Some((gap, lower)),
            axis: None,
        };
    }
    let mut ascent = AxisAscent::start(sa, &a.pose_after(0.0), sb, &b.pose_after(0.0), start);
    let first = match first {
        Some(lower) => lower,
        None => {
            ascent.step_to(sa, sb, 1);
            let lower = ascent.gap().safe_time(sa, a, sb, b);
            if lower >= horizon {
                return QuickBound {
                    lower,
                    estimate: lower,
                    now: None,
                    axis: Some(ascent.next_axis()),
                };
            }
            lower
        }
    };
    ascent.finish(sa, sb);
    let gap = ascent.gap();
    // Both gaps bound the distance; the safe time of either is rigorous.
    let safe = gap.safe_time(sa, a, sb, b);
    let lower = safe.max(first);
    QuickBound {
        lower,
        estimate: gap.closing_estimate(a, b).max(lower),
        now: Some((gap, safe)),
        axis: Some(ascent.next_axis()),
    }
}

/// [`separating_axis`] for needles and plates, whose largest radius of curvature (aspect² times
/// the smallest semi-axis: 100 at X0 = 10 and 0.1) damps the ascent to a standstill.
///
/// Ellipsoids take the normal along which they touch once scaled by their Perram–Wertheim
/// contact scale μ ([`pw::contact_normal_lab`]): there r·n = μ(h_A + h_B), so the gap
/// (μ − 1)(h_A + h_B) is the distance to first order in μ − 1, for a maximisation of F(λ) over
/// one variable (X0 = 10: 2.3 times fewer instructions than the iterations below, and half the
/// distances per collision; MEASUREMENTS.md, "Needles and plates"). Other shapes take the best
/// axis of a few iterations of Gilbert's algorithm ([`certify`]), and bodies it proves
/// overlapping the line of centres. Every gap is measured on the bodies' own support points, so
/// any axis gives as rigorous a lower bound of the distance.
fn elongated_axis<S: Surface>(sa: &S, pa: &Pose, sb: &S, pb: &Pose) -> AxisGap {
    let r = pb.r - pa.r;
    let normal = match (sa.ellipsoid_semi_axes(), sb.ellipsoid_semi_axes()) {
        (Some(ea), Some(eb)) => {
            let (a, b) = (lab_matrix(&ea, &pa.rot), lab_matrix(&eb, &pb.rot));
            Some(pw::contact_normal_lab(&a, &b, &r))
        }
        _ => None,
    };
    let n = match normal.filter(|n| n.iter().all(|x| x.is_finite())) {
        Some(n) => n,
        None => {
            let l = sa.semi_axes().min().min(sb.semi_axes().min());
            match certify(sa, pa, sb, pb, GILBERT_AXIS_TOL * l, GILBERT_AXIS_ITER) {
                Certified::Apart { n, .. } | Certified::Undecided { n, .. } => n,
                Certified::Overlapping { .. } => r.normalize(),
            }
        }
    };
    // Gilbert's support points along its axis are these very ones.
    let (xa, xb) = (
        support_point_lab(sa, pa, &n),
        support_point_lab(sb, pb, &-n),
    );
    AxisGap {
        gap: n.dot(&(xb - xa)),
        n,
        offset_a: xa - pa.r,
        offset_b: xb - pb.r,
        rot_a: pa.rot,
        rot_b: pb.rot,
        kept: [f64::NAN; 2],
    }
}

/// How close Gilbert's iterations in [`elongated_axis`] bring its gap to the distance (in units
/// of the smallest semi-axis), and the iterations they may take for it.
const GILBERT_AXIS_TOL: f64 = 0.05;
const GILBERT_AXIS_ITER: u32 = 16;

/// The largest radius of curvature, or where a flat face has none the half-diagonal of the box
/// of the semi-axes: a step length only. A superquadric's bounding radius was about that long
/// until it became exact (`farthest_point` in `superquadric.rs`); as the step length, the exact
/// one cost p = 10 4 % more instructions.
fn search_radius<S: Surface>(s: &S) -> f64 {
    let rho = s.max_curvature_radius();
    if rho.is_finite() {
        rho
    } else {
        s.semi_axes().norm()
    }
}

impl AxisGap {
    /// How long A and B (moving freely from the poses the gap was found at) provably stay apart.
    pub fn safe_time<S: Surface>(&self, sa: &S, a: &Body, sb: &S, b: &Body) -> f64 {
        if self.gap.is_nan() || self.gap <= 0.0 {
            return 0.0;
        }
        gap_safe_time(
            &GapSide::kept(sa, a, &self.rot_a, self.offset_a, &self.n, self.kept[0]),
            &GapSide::kept(sb, b, &self.rot_b, self.offset_b, &-self.n, self.kept[1]),
            &self.n,
            self.gap,
        )
    }

    /// The support points and their gap as a start for Newton–Raphson, which needs the
    /// multipliers too; `pa` and `pb` are the poses the gap was found at.
    fn support_start<S: Surface>(&self, sa: &S, pa: &Pose, sb: &S, pb: &Pose) -> Distance {
        let (xa, xb) = (pa.r + self.offset_a, pb.r + self.offset_b);
        let (alpha, beta) = multipliers_guess(sa, pa, sb, pb, &xa, &xb);
        Distance {
            d: self.gap,
            xa,
            xb,
            alpha,
            beta,
        }
    }

    /// The time the gap takes to close at its present rate (+∞ if it opens): an estimate to
    /// order searches by.
    pub fn closing_estimate(&self, a: &Body, b: &Body) -> f64 {
        let rate = self
            .n
            .dot(&((b.v + b.w.cross(&self.offset_b)) - (a.v + a.w.cross(&self.offset_a))));
        if self.gap > 0.0 && rate < 0.0 {
            self.gap / -rate
        } else if self.gap > 0.0 {
            f64::INFINITY
        } else {
            0.0
        }
    }
}

/// [t1, t2] during which the bounding spheres (radii summing to `sigma`) overlap (Sec. 2.4.2).
pub fn bounding_sphere_window(r: &V3, v: &V3, sigma: f64) -> Option<(f64, f64)> {
    let c = r.norm_squared() - sigma * sigma;
    let b = r.dot(v);
    let vv = v.norm_squared();
    if c < 0.0 {
        if vv == 0.0 {
            return Some((0.0, f64::INFINITY));
        }
        let disc = b * b - vv * c;
        return Some((0.0, (-b + disc.sqrt()) / vv));
    }
    if b >= 0.0 {
        return None;
    }
    let disc = b * b - vv * c;
    if disc < 0.0 {
        return None;
    }
    let q = -b + disc.sqrt();
    Some((c / q, q / vv))
}

/// Whether the contact points approach along A's outward normal at the closest point.
fn approaching<S: Surface>(sa: &S, a: &Body, b: &Body, d: &Distance, t: f64) -> bool {
    let pa = a.pose_after(t);
    let pb = b.pose_after(t);
    let n = sa.place(&pa).grad(&d.xa);
    let xc = (d.xa + d.xb) * 0.5;
    let u = (a.v + a.w.cross(&(xc - pa.r))) - (b.v + b.w.cross(&(xc - pb.r)));
    u.dot(&n) > 0.0
}

/// What a speculative jump past the estimated contact found.
enum Jump {
    /// The first contact, proved.
    Hit(Hit),
    /// An overlap at the end of the jump, but no contact proved the first; the contact refined,
    /// where the interval before it that is proved free of contact is known.
    Unproved(Option<Candidate>),
    /// The bodies still apart at its end: nothing learnt.
    Short,
}

/// A contact (d = 0, the bodies approaching) that comes first unless another comes before
/// `free_after`: no contact is possible in [`free_after`, `hit.t`). The search returns it once its
/// stepping has proved everything before `free_after` free instead of stepping on to the contact
/// and refining it again. On flat faces 8,500 of 19,600 jumps' contacts were not proved the
/// first (the interval before a contact, from the support modulus, is short): kept, they took
/// SQ p = 10 (X0 = 2, φ = 0.256, N 512, NNL) from 34.4 to 30.5 distances per collision.
#[derive(Clone, Copy, Debug)]
struct Candidate {
    hit: Hit,
    free_after: f64,
}

/// What [`Search::first_contact_after`] proves of a contact.
enum Proof {
    First,
    /// No contact in [t, contact): whether one comes before t is not known.
    FreeAfter(f64),
    Nothing,
}

struct Search<'a, S: Surface> {
    sa: &'a S,
    a: &'a Body,
    sb: &'a S,
    b: &'a Body,
    /// The bodies' flights, which give their poses ([`Flight`]).
    fa: Flight<'a>,
    fb: Flight<'a>,
    p: &'a ContactParams,
    stats: &'a mut SolverStats,
}

impl<'a, S: Surface> Search<'a, S> {
    fn new(
        sa: &'a S,
        a: &'a Body,
        sb: &'a S,
        b: &'a Body,
        p: &'a ContactParams,
        stats: &'a mut SolverStats,
    ) -> Self {
        Search {
            sa,
            a,
            sb,
            b,
            fa: Flight::of(a),
            fb: Flight::of(b),
            p,
            stats,
        }
    }

    fn dist(&mut self, t: f64, warm: Option<&Distance>) -> Option<Distance> {
        let pa = self.fa.pose_after(t);
        let pb = self.fb.pose_after(t);
        // Successive times are close, so the previous closest point is a good start as it stands.
        let g: Option<Guess> = warm.map(|w| Guess {
            xa_body: pa.to_body(&w.xa),
            alpha: w.alpha,
            beta: w.beta,
        });
        distance(
            self.sa,
            &pa,
            self.sb,
            &pb,
            g.as_ref(),
            &self.p.tol,
            self.stats,
        )
    }

    /// How long after (or before) `t` the bodies, `d` apart at `t`, provably do not touch: the
    /// support gap along the contact normal equals d at t (the closest points are the support
    /// points) and bounds it from below at every other time ([`gap_safe_time_towards`]). Each
    /// closest point is exactly the support point along its own normal, which matches n to the
    /// solver's tolerance ε: anchoring each body's bound there (its support modulus holds for
    /// any u) changes the bound by terms of order ε, however fast a flat face's support point
    /// runs with the direction. The support points along a separating axis, `d` their gap, are
    /// such points too.
    fn safe_time_towards(&self, t: f64, d: &Distance, towards: Towards) -> f64 {
        let pa = self.fa.pose_after(t);
        let pb = self.fb.pose_after(t);
        let n = self.sa.place(&pa).grad(&d.xa).normalize();
        gap_safe_time_towards(
            &GapSide::new(self.sa, self.a, &pa.rot, d.xa - pa.r, &n),
            &GapSide::new(self.sb, self.b, &pb.rot, d.xb - pb.r, &-n),
            &n,
            d.d.max(0.0),
            towards,
        )
    }

    fn safe_time(&self, t: f64, d: &Distance) -> f64 {
        self.safe_time_towards(t, d, Towards::Future)
    }

    /// The two-sided test (not in the paper): d > 0 throughout [t0, t0 + dt] follows from d at
    /// both ends when the contact-free interval `forward` after t0 covers it, or the one
    /// backwards from t0 + dt (where d is `hi`) covers the rest.
    fn covered_backwards(&self, forward: f64, t0: f64, hi: &Distance, dt: f64) -> bool {
        hi.d > 0.0
            && (forward >= dt || forward + self.safe_time_towards(t0 + dt, hi, Towards::Past) >= dt)
    }

    /// Whether the contact `h`, found beyond t0 (where the bodies are `d0` apart, or `d0` holds
    /// their support points along a separating axis and its gap), is the first after t0. The
    /// support gap g along the contact normal n bounds d from below at every time and is zero
    /// at the contact, where it closes at the rate ġ < 0; with |g̈| ≤ M
    /// ([`support_acceleration_bound`]), g(t_c − s) ≥ |ġ|s − ½Ms² > 0 for 0 < s < 2|ġ|/M; on
    /// flat faces (M = ∞) g(t_c − s) ≥ |ġ|s − P(s) with the powers P of the support modulus
    /// ([`gap_safe_time_towards`] backwards from g = 0). The
    /// rest of [t0, t_c], if any, must pass the two-sided test of [`Search::covered_backwards`]
    /// with one more distance (at 90 % of that window before the contact).
    fn first_contact_after(&mut self, t0: f64, d0: &Distance, h: &Hit) -> Proof {
        let (a, b) = (self.a, self.b);
        let (pa, pb) = (self.fa.pose_after(h.t), self.fb.pose_after(h.t));
        let rate =
            h.n.dot(&((b.v + b.w.cross(&(h.xc - pb.r))) - (a.v + a.w.cross(&(h.xc - pa.r)))));
        let m = support_acceleration_bound(
            &a.w,
            &h.n,
            self.sa.bounding_radius(),
            self.sa.max_curvature_radius(),
            self.sa.min_support(),
        ) + support_acceleration_bound(
            &b.w,
            &h.n,
            self.sb.bounding_radius(),
            self.sb.max_curvature_radius(),
            self.sb.min_support(),
        );
        if !(rate < 0.0 && h.t > t0) {
            return Proof::Nothing;
        }
        let window = if m.is_finite() {
            2.0 * -rate / m
        } else {
            // A flat face has no curvature bound: the powers of its support modulus bound how
            // the gap along n reopens backwards from the contact instead (g = 0 there).
            gap_safe_time_towards(
                &GapSide::new(self.sa, a, &pa.rot, h.xc - pa.r, &h.n),
                &GapSide::new(self.sb, b, &pb.rot, h.xc - pb.r, &-h.n),
                &h.n,
                0.0,
                Towards::Past,
            )
        };
        let tv = h.t - 0.9 * window;
        if tv <= t0 {
            return Proof::First;
        }
        // The contact-free interval forwards from t0 may reach tv alone: then no distance at tv.
        let forward = self.safe_time_towards(t0, d0, Towards::Future);
        let dt = tv - t0;
        if d0.d > 0.0 && forward >= dt {
            return Proof::First;
        }
        match self.dist(tv, Some(d0)) {
            Some(dv) if dv.d > 0.0 => {
                // [`Search::covered_backwards`], with the backward interval from tv kept: where
                // the two do not meet, [tv − backward, contact) is still proved free.
                let backward = self.safe_time_towards(tv, &dv, Towards::Past);
                if d0.d > 0.0 && forward + backward >= dt {
                    Proof::First
                } else {
                    Proof::FreeAfter(tv - backward)
                }
            }
            _ => Proof::Nothing,
        }
    }

    fn dist_value(&mut self, t: f64, warm: &mut Distance) -> f64 {
        match self.dist(t, Some(warm)) {
            Some(d) => {
                *warm = d;
                d.d
            }
            None => f64::NAN,
        }
    }

    /// Like `dist_value` inside a bracket whose far end may lie deep in an overlap, where Eqs. (9)
    /// have no solution: a failure there means "overlapping" (−∞), not a solver failure.
    fn probe(&mut self, t: f64, warm: &mut Distance) -> f64 {
        let before = self.stats.failures;
        let d = self.dist_value(t, warm);
        if d.is_nan() {
            self.stats.failures = before;
            return f64::NEG_INFINITY;
        }
        d
    }

    /// Newton–Raphson on Eqs. (30) from the linear estimate t0 + d/|ḋ| of the contact (`slope`
    /// is ḋ at t0 < 0), started at the closest points of t0 carried there with their bodies: the
    /// contact it converges to before `t_hi`, which [`Search::first_contact_after`] proves the
    /// first after t0. `d0` may also be the support points along a separating axis, `d` their
    /// gap: each is the support point along its own normal, as closest points are. A converged
    /// solution of Eqs. (30) is a contact (both surfaces through x, their normals opposite), so
    /// no bracket is needed; `None` where Newton–Raphson does not converge or nothing is proved.
    fn direct(&mut self, t0: f64, d0: &Distance, slope: f64, t_hi: f64) -> Option<Hit> {
        let te = t0 + d0.d / -slope;
        let x = self.carried_midpoint(t0, d0, te);
        let h = self.newton_contact(x, d0.alpha, te, t0, t_hi)?;
        // A first contact is one the bodies approach at (its proof asks for ġ < 0 there).
        matches!(self.first_contact_after(t0, d0, &h), Proof::First).then_some(h)
    }

    /// A speculative jump from t0 (the bodies `d0` apart) to ts, past the estimated contact: where
    /// it lands in an overlap, the contact refined from [t0, ts] if it is proved the first after
    /// t0 ([`Search::first_contact_after`]). Landing deep in an overlap, where no distance exists,
    /// is expected and not counted as a solver failure.
    fn speculate(&mut self, t0: f64, d0: &Distance, ts: f64) -> Jump {
        let failures_before = self.stats.failures;
        match self.dist(ts, Some(d0)) {
            Some(sd) if sd.d < 0.0 => {
                let candidate = match self.refine(t0, d0, ts, &sd) {
                    Some(h) => match self.first_contact_after(t0, d0, &h) {
                        Proof::First => return Jump::Hit(h),
                        Proof::FreeAfter(free_after) => Some(Candidate { hit: h, free_after }),
                        Proof::Nothing => None,
                    },
                    None => None,
                };
                self.stats.failures = failures_before;
                Jump::Unproved(candidate)
            }
            Some(_) => Jump::Short,
            None => {
                self.stats.failures = failures_before;
                Jump::Short
            }
        }
    }

    /// Steps 5 and 6a: the bracket [t_lo, t_hi] holds a sign change of d.
    ///
    /// Newton–Raphson on Eqs. (30) starts first from what the bracket already tells, without a
    /// distance: the first zero of the parabola through both ends with the exact slope ḋ at t_lo
    /// ([`Search::slope`]), and the closest points of t_lo carried there with their bodies. Only
    /// where that fails, the paper's way: distances at the middle and at the parabola's zero.
    fn refine(&mut self, t_lo: f64, d_lo: &Distance, t_hi: f64, d_hi: &Distance) -> Option<Hit> {
        let tm = 0.5 * (t_lo + t_hi);
        let (h, slope) = (t_hi - t_lo, self.slope(t_lo, d_lo));
        let curv = (d_hi.d - d_lo.d - slope * h) / (h * h);
        let dm = d_lo.d + slope * 0.5 * h + curv * 0.25 * h * h;
        if let Some(tz) = first_zero_of_parabola(t_lo, d_lo.d, tm, dm, t_hi, d_hi.d) {
            let x = self.carried_midpoint(t_lo, d_lo, tz);
            // A bracket may hold an exit too: a contact of parting bodies is not the one sought.
            if let Some(hit) = self.newton_contact(x, d_lo.alpha, tz, t_lo, t_hi)
                && self.closing_at(&hit)
            {
                return Some(hit);
            }
        }
        let mut w = *d_lo;
        let dm = self.probe(tm, &mut w);
        let tz = if dm.is_finite() {
            first_zero_of_parabola(t_lo, d_lo.d, tm, dm, t_hi, d_hi.d)
        } else {
            None
        }
        .unwrap_or(t_lo + (t_hi - t_lo) * d_lo.d / (d_lo.d - d_hi.d));
        let mut w = *d_lo;
        let dz = self.probe(tz, &mut w);
        let start = if dz.is_finite() { w } else { *d_lo };
        let x = (start.xa + start.xb) * 0.5;
        if let Some(h) = self.newton_contact(x, start.alpha, tz, t_lo, t_hi)
            && self.closing_at(&h)
        {
            return Some(h);
        }
        self.stats.contact_fallbacks += 1;
        self.bisect(t_lo, d_lo, t_hi)
    }

    /// Step 6: both ends closer than ε_d; look for a negative minimum in between.
    fn grazing(&mut self, t0: f64, d0: &Distance, t2: f64, d2: &Distance) -> Option<Hit> {
        let t1 = 0.5 * (t0 + t2);
        let mut w = *d0;
        let d1 = self.dist_value(t1, &mut w);
        if !d1.is_finite() {
            return None;
        }
        if d1 < 0.0 {
            return self.refine(t0, d0, t1, &w);
        }
        let h = 0.5 * (t2 - t0);
        let curv = (d0.d - 2.0 * d1 + d2.d) / (2.0 * h * h);
        if curv <= 0.0 {
            return None; // (c) no minimum
        }
        let slope = (4.0 * d1 - 3.0 * d0.d - d2.d) / (2.0 * h);
        let sm = -slope / (2.0 * curv);
        if !(0.0..=2.0 * h).contains(&sm) {
            return None;
        }
        let tm = t0 + sm;
        let pm = d0.d - slope * slope / (4.0 * curv);
        if pm < 0.0 {
            // (a) the parabola dips below zero: check the true distance at its minimum.
            let mut wm = *d0;
            let dm = self.dist_value(tm, &mut wm);
            if dm < 0.0 {
                return self.refine(t0, d0, tm, &wm);
            }
        }
        // (b) minimise d(t) with Brent's method, as accurately as the scene asks.
        let mut wb = *d0;
        let (tb, db) = brent_min(t0, tm, t2, self.p.brent_tol / ddot_scale(self), |t| {
            self.dist_value(t, &mut wb)
        });
        if db < 0.0 {
            let mut wz = *d0;
            let dz = self.dist_value(tb, &mut wz);
            if dz < 0.0 {
                return self.refine(t0, d0, tb, &wz);
            }
        }
        None
    }

    /// Newton–Raphson on Eqs. (30) with the Jacobian of Eq. (31); unknowns (x, α, t), started from
    /// the point `x`, the multiplier `alpha` and the time `t0`.
    fn newton_contact(
        &mut self,
        mut x: V3,
        mut alpha: f64,
        t0: f64,
        t_lo: f64,
        t_hi: f64,
    ) -> Option<Hit> {
        let (a, b) = (self.a, self.b);
        let mut t = t0;
        let tol = self.p.tol;
        let slack = 1e-9 * (t_hi - t_lo) + 1e-15 * t_hi.abs();
        self.stats.contact_solves += 1;
        for _ in 0..tol.nr_max_iter {
            self.stats.nr_iterations += 1;
            let pa = self.fa.pose_after(t);
            let pb = self.fb.pose_after(t);
            let ea = self.sa.place(&pa).eval(&x);
            let eb = self.sb.place(&pb).eval(&x);
            let ua = a.v + a.w.cross(&(x - pa.r));
            let ub = b.v + b.w.cross(&(x - pb.r));
            let a2 = alpha * alpha;
            let f1 = ea.grad + eb.grad * a2;
            let fxn = ea.grad.norm();
            if f1.norm() <= tol.nr_tol * fxn && ea.f.abs() <= tol.nr_tol && eb.f.abs() <= tol.nr_tol
            {
                if t < t_lo - slack || t > t_hi + slack {
                    return None;
                }
                return Some(Hit {
                    t: t.clamp(0.0, f64::INFINITY),
                    xc: x,
                    n: ea.grad / fxn,
                });
            }
            // ∂f/∂t = −f_x·u and ∂f_x/∂t = w × f_x − H u, with u the velocity of the material point.
            let ft = -ea.grad.dot(&ua);
            let gt = -eb.grad.dot(&ub);
            let fxt = a.w.cross(&ea.grad) - ea.hess * ua;
            let gxt = b.w.cross(&eb.grad) - eb.hess * ub;
            let jacobian = Bordered {
                a: ea.hess + eb.hess * a2,
                u: eb.grad * (2.0 * alpha),
                w: fxt + gxt * a2,
                f: ea.grad,
                g: eb.grad,
                d: [[0.0, ft], [0.0, gt]],
            };
            let s = jacobian.solve(&-f1, -ea.f, -eb.f)?;
            let mut xi: f64 = 1.0;
            let da2 = (2.0 * alpha * s[3]).abs();
            if da2 > tol.nr_relax * a2 {
                xi = tol.nr_relax * a2 / da2;
            }
            x += s.fixed_rows::<3>(0) * xi;
            alpha = (alpha + xi * s[3]).abs();
            t += xi * s[4];
            if !(t.is_finite() && alpha.is_finite() && alpha > 0.0) {
                return None;
            }
        }
        None
    }

    /// ḋ at `t`, where the bodies are `d` apart: the closest points' relative velocity along the
    /// normal (the terms of the turning normal vanish, x_B − x_A being parallel to it).
    fn slope(&self, t: f64, d: &Distance) -> f64 {
        let (a, b) = (self.a, self.b);
        let (pa, pb) = (self.fa.pose_after(t), self.fb.pose_after(t));
        let n = self.sa.place(&pa).grad(&d.xa).normalize();
        let ua = a.v + a.w.cross(&(d.xa - pa.r));
        let ub = b.v + b.w.cross(&(d.xb - pb.r));
        n.dot(&(ub - ua))
    }

    /// Whether the bodies approach at the contact `h` (the collision rule's u·n > 0).
    fn closing_at(&self, h: &Hit) -> bool {
        let (a, b) = (self.a, self.b);
        let (pa, pb) = (self.fa.pose_after(h.t), self.fb.pose_after(h.t));
        let u = (a.v + a.w.cross(&(h.xc - pa.r))) - (b.v + b.w.cross(&(h.xc - pb.r)));
        u.dot(&h.n) > 0.0
    }

    /// The midpoint of the closest points of time `t`, each carried with its body to time `to`.
    fn carried_midpoint(&self, t: f64, d: &Distance, to: f64) -> V3 {
        // The poses of `t` first, which a flight has kept (the slope was just taken there), then
        // those of `to`, which it keeps for Newton–Raphson's first step.
        let (xa, xb) = (
            self.fa.pose_after(t).to_body(&d.xa),
            self.fb.pose_after(t).to_body(&d.xb),
        );
        (self.fa.pose_after(to).to_lab(&xa) + self.fb.pose_after(to).to_lab(&xb)) * 0.5
    }

    /// Fallback when Newton–Raphson on Eqs. (30) fails: bisection of d(t) to the Brent tolerance.
    fn bisect(&mut self, mut lo: f64, d_lo: &Distance, mut hi: f64) -> Option<Hit> {
        let mut w = *d_lo;
        let mut best = *d_lo;
        let dt_tol = self.p.brent_tol / ddot_scale(self);
        while hi - lo > dt_tol {
            let m = 0.5 * (lo + hi);
            let dm = self.probe(m, &mut w);
            if dm > 0.0 {
                lo = m;
                best = w;
            } else {
                hi = m;
            }
        }
        Some(self.hit_from_distance(&best, lo))
    }

    fn hit_from_distance(&self, d: &Distance, t: f64) -> Hit {
        let pa = self.fa.pose_after(t);
        let xc = (d.xa + d.xb) * 0.5;
        let g = self.sa.place(&pa).grad(&d.xa);
        Hit {
            t,
            xc,
            n: g.normalize(),
        }
    }
}

fn ddot_scale<S: Surface>(s: &Search<'_, S>) -> f64 {
    ddot_max(s.a, s.b, s.sa.bounding_radius(), s.sb.bounding_radius())
}

/// First zero in [t0, t2] of the parabola through three points (t1 the midpoint).
pub fn first_zero_of_parabola(t0: f64, d0: f64, t1: f64, d1: f64, t2: f64, d2: f64) -> Option<f64> {
    let h = t1 - t0;
    let a = (d0 - 2.0 * d1 + d2) / (2.0 * h * h);
    let b = (4.0 * d1 - 3.0 * d0 - d2) / (2.0 * h);
    let c = d0;
    let roots = if a.abs() < 1e-300 {
        if b == 0.0 {
            return None;
        }
        [-c / b, f64::NAN]
    } else {
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            return None;
        }
        let q = -0.5 * (b + b.signum() * disc.sqrt());
        [q / a, c / q]
    };
    roots
        .into_iter()
        .filter(|s| s.is_finite() && *s >= 0.0 && *s <= t2 - t0)
        .fold(None, |m: Option<f64>, s| Some(m.map_or(s, |m| m.min(s))))
        .map(|s| t0 + s)
}

/// Brent's minimisation on [a, c] starting from b (Numerical Recipes' `brent`), to absolute `tol`.
pub fn brent_min(a: f64, b: f64, c: f64, tol: f64, mut f: impl FnMut(f64) -> f64) -> (f64, f64) {
    const CGOLD: f64 = 0.381_966_011_250_105;
    let (mut lo, mut hi) = (a.min(c), a.max(c));
    let (mut x, mut w, mut v) = (b, b, b);
    let mut fx = f(x);
    let (mut fw, mut fv) = (fx, fx);
    let (mut d, mut e): (f64, f64) = (0.0, 0.0);
    for _ in 0..200 {
        let xm = 0.5 * (lo + hi);
        let tol1 = tol + 1e-12 * x.abs();
        let tol2 = 2.0 * tol1;
        if (x - xm).abs() <= tol2 - 0.5 * (hi - lo) {
            break;
        }
        let mut golden = true;
        if e.abs() > tol1 {
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            let etemp = e;
            e = d;
            if !(p.abs() >= (0.5 * q * etemp).abs() || p <= q * (lo - x) || p >= q * (hi - x)) {
                d = p / q;
                let u = x + d;
                if u - lo < tol2 || hi - u < tol2 {
                    d = tol1.copysign(xm - x);
                }
                golden = false;
            }
        }
        if golden {
            e = if x >= xm { lo - x } else { hi - x };
            d = CGOLD * e;
        }
        let u = if d.abs() >= tol1 {
            x + d
        } else {
            x + tol1.copysign(d)
        };
        let fu = f(u);
        if !fu.is_finite() {
            break;
        }
        if fu <= fx {
            if u >= x {
                lo = x;
            } else {
                hi = x;
            }
            (v, w, x) = (w, x, u);
            (fv, fw, fx) = (fw, fx, fu);
        } else {
            if u < x {
                lo = u;
            } else {
                hi = u;
            }
            if fu <= fw || w == x {
                (v, w) = (w, u);
                (fv, fw) = (fw, fu);
            } else if fu <= fv || v == x || v == w {
                v = u;
                fv = fu;
            }
        }
    }
    (x, fx)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ellipsoid::Ellipsoid;
    use crate::rigid::rotate;

    /// Needles and plates (X0 = 10 and 0.1, volume π/6) apart by up to 30 % more than where
    /// they touch, in random orientations: the separating-axis gap ([`elongated_axis`]) never
    /// exceeds the distance Gilbert's algorithm certifies to 1e-10, and comes within a tenth of
    /// the smallest semi-axis of it on average (the damped ascent, which stayed near the line of
    /// centres, fell 3.6 semi-axes short at X0 = 10). Ellipsoids take the Perram–Wertheim
    /// normal, superquadrics (exponents [2, 2, 4]) Gilbert's iterations.
    #[test]
    fn the_separating_axis_of_needles_and_plates_bounds_the_distance_closely() {
        let mut rng = crate::rng::Rng::new(31);
        for x0 in [10.0f64, 0.1] {
            let b = 0.5 / x0.cbrt();
            let e = Ellipsoid::new(x0 * b, b, b);
            let shortfall = mean_shortfall(&e, 300, &mut rng, &|ra, rb, r| {
                crate::pw::contact_scale(&e, ra, &e, rb, r)
            });
            assert!(shortfall <= 0.1, "X0 {x0}: mean shortfall {shortfall}");
            let q = crate::superquadric::Superquadric::with_unit_volume(
                [x0, 1.0, 1.0],
                [2.0, 2.0, 4.0],
            )
            .expect("a valid superquadric");
            let shortfall = mean_shortfall(&q, 60, &mut rng, &|ra, rb, r| {
                crate::scale::contact_scale(&q, ra, &q, rb, r)
            });
            assert!(
                shortfall <= 0.1,
                "superquadric X0 {x0}: mean shortfall {shortfall}"
            );
        }
    }

    /// Over `pairs` pairs of `s` placed 0.1–30 % beyond contact (`scale` gives their contact
    /// scale), the mean of how far the separating-axis gap falls short of the certified distance,
    /// in smallest semi-axes; asserts that it never exceeds the distance.
    fn mean_shortfall<S: Surface>(
        s: &S,
        pairs: usize,
        rng: &mut crate::rng::Rng,
        scale: &dyn Fn(&M3, &M3, &V3) -> f64,
    ) -> f64 {
        let l = s.semi_axes().min();
        let mut shortfall = 0.0;
        for _ in 0..pairs {
            let mut rot = || {
                let axis = V3::new(rng.normal(), rng.normal(), rng.normal());
                rotate(&M3::identity(), &axis, 1.0)
            };
            let (ra, rb) = (rot(), rot());
            let dir = V3::new(rng.normal(), rng.normal(), rng.normal());
            let touching = dir / scale(&ra, &rb, &dir);
            let pa = Pose {
                r: V3::zeros(),
                rot: ra,
            };
            let pb = Pose {
                r: touching * (1.001 + 0.3 * rng.uniform()),
                rot: rb,
            };
            let gap = separating_axis(s, &pa, s, &pb).gap;
            let Certified::Apart { lower, upper, .. } =
                certify(s, &pa, s, &pb, 1e-10 * l, 1_000_000)
            else {
                panic!("apart bodies not certified")
            };
            assert!(gap <= upper + 1e-12, "gap {gap} above the distance {upper}");
            shortfall += (lower - gap) / l;
        }
        shortfall / pairs as f64
    }

    #[test]
    fn brent_finds_parabola_minimum() {
        let (x, fx) = brent_min(0.0, 0.3, 1.0, 1e-12, |t| (t - 0.7) * (t - 0.7) + 1e-9);
        assert!((x - 0.7).abs() < 1e-6);
        assert!((fx - 1e-9).abs() < 1e-12);
    }

    #[test]
    fn parabola_zero() {
        // d(t) = 1 − t² on [0, 2]: first zero at 1.
        let z = first_zero_of_parabola(0.0, 1.0, 1.0, 0.0, 2.0, -3.0).unwrap();
        assert!((z - 1.0).abs() < 1e-14);
    }

    /// A pair [`spinning_alike`] at random, spinning fast (|w| about 10), between `near` and
    /// `far` beyond their contact along the line of centres, and moving towards each other along
    /// it (with a sideways drift).
    fn closing_alike(
        rng: &mut crate::rng::Rng,
        q: &crate::superquadric::Superquadric,
        near: f64,
        far: f64,
    ) -> (Body, Body, impl Fn(f64) -> f64) {
        let mut normal = || V3::new(rng.normal(), rng.normal(), rng.normal());
        let rot = rotate(&M3::identity(), &normal(), 1.0);
        let (dir, w) = (normal().normalize(), normal() * 6.0);
        let beyond = rng.range(near, far);
        let v =
            -dir * rng.range(0.05, 2.0) + V3::new(rng.normal(), rng.normal(), rng.normal()) * 0.5;
        spinning_alike(q, rot, w, dir, beyond, v)
    }

    /// The contact parameters of the searches on bodies [`spinning_alike`].
    fn spinning_params() -> ContactParams {
        ContactParams {
            eps_d: 1e-5,
            brent_tol: 1e-12,
            tol: crate::distance::Tolerances::default(),
        }
    }

    /// Two copies of superquadric `q` turned alike (`rot`) and spinning alike (`w`): A at rest at
    /// the origin, B along the unit `dir` at `beyond` past where they touch, moving at `v`; and
    /// the exact overlap test of such a pair at time t, negative exactly where they overlap: they
    /// keep one orientation at every time, and B = A + r meets A where r ∈ 2A, so the test is f
    /// at half the separation in the common body frame.
    fn spinning_alike(
        q: &crate::superquadric::Superquadric,
        rot: M3,
        w: V3,
        dir: V3,
        beyond: f64,
        v: V3,
    ) -> (Body, Body, impl Fn(f64) -> f64) {
        let (mut lo, mut hi) = (0.0, 4.0 * q.bounding_radius());
        for _ in 0..60 {
            let m = 0.5 * (lo + hi);
            if q.f(&(rot * dir * (0.5 * m))) < 0.0 {
                lo = m
            } else {
                hi = m
            }
        }
        let r = dir * (hi + beyond);
        let body = |r: V3, v: V3| Body {
            r,
            v,
            rot,
            w,
            t: 0.0,
        };
        let q = *q;
        let overlap = move |t: f64| q.f(&(rotate(&rot, &w, t) * (r + v * t) * 0.5));
        (body(V3::zeros(), V3::zeros()), body(r, v), overlap)
    }

    /// [`enclosing_bound`] comes before any contact: superquadrics of the figures' shapes (round
    /// across one axis: cylinders), of unequal exponents (boxes) and ellipsoids, each body in its
    /// own orientation and spin, from nearly touching to over a body length apart, along the
    /// line of centres and random axes. Gilbert's algorithm ([`certify`]) finds a point inside
    /// both nowhere before the bound, and bodies that do not turn, along an axis of both, get the
    /// gap over the closing speed.
    #[test]
    fn the_enclosing_bound_comes_before_any_contact() {
        use crate::superquadric::Superquadric;
        const W_UPRIGHT: f64 = 3.0;
        let mut rng = crate::rng::Rng::new(41);
        let (mut checked, mut bounded) = (0, 0);
        for case in 0..800 {
            let e = [[2.0, 2.0, 10.0], [4.0, 2.0, 2.0], [3.0, 6.0, 2.5], [2.0; 3]][case % 4];
            let x0 = [0.5, 2.0][(case / 4) % 2];
            let q = Superquadric::with_unit_volume([x0, 1.0, 1.0], e).unwrap();
            let normal =
                |rng: &mut crate::rng::Rng| V3::new(rng.normal(), rng.normal(), rng.normal());
            let (dir, axis) = (normal(&mut rng).normalize(), normal(&mut rng).normalize());
            let moving = |r: V3, v: V3, rng: &mut crate::rng::Rng| Body {
                r,
                v,
                rot: rotate(&M3::identity(), &normal(rng), 1.0),
                w: normal(rng) * 3.0,
                t: 0.0,
            };
            let a = moving(V3::zeros(), V3::zeros(), &mut rng);
            let apart = 2.0 * q.bounding_radius() * rng.range(0.3, 1.5);
            let v = normal(&mut rng) * 0.5 - dir * rng.range(0.0, 2.0);
            let b = moving(dir * apart, v, &mut rng);
            let at = |t: f64| certify(&q, &a.pose_after(t), &q, &b.pose_after(t), 1e-10, 200);
            if matches!(at(0.0), Certified::Overlapping { .. }) {
                continue;
            }
            checked += 1;
            let n = if case % 2 == 0 { dir } else { axis };
            let lower = enclosing_bound(&q, &a, &q, &b, &n);
            assert!(lower >= 0.0, "case {case}: {lower}");
            if lower > 0.0 {
                bounded += 1;
            }
            let end = lower.min(3.0);
            for k in 0..=50 {
                let t = end * f64::from(k) / 50.0;
                assert!(
                    !matches!(at(t), Certified::Overlapping { .. }),
                    "case {case}: overlap at {t} before the bound {lower}"
                );
            }
        }
        assert!(
            checked > 500 && bounded > checked / 4,
            "{checked} checked, {bounded} bounded"
        );
        // Along axis 2 of both, neither turning: the ends of the cylinders, gap 0.1, closing at 2.
        let q = Superquadric::with_unit_volume([2.0, 1.0, 1.0], [2.0, 2.0, 10.0]).unwrap();
        let still = |r: V3, v: V3| Body {
            r,
            v,
            rot: M3::identity(),
            w: V3::zeros(),
            t: 0.0,
        };
        let c = q.s[2];
        let a = still(V3::zeros(), V3::zeros());
        let b = still(V3::new(0.0, 0.0, 2.0 * c + 0.1), V3::new(0.3, 0.0, -2.0));
        let lower = enclosing_bound(&q, &a, &q, &b, &V3::z());
        assert!((lower - 0.05).abs() < 1e-12, "{lower}");
        // A needle at 45° turning upright under a plate that does not turn: its support rises at
        // 0.7 L|w| at first, where the bound allows L|w|. They meet after the bound, and soon.
        let needle = Superquadric::new([2.0, 0.2, 0.2], [2.0; 3]).unwrap();
        let plate = Superquadric::new([3.0, 3.0, 0.2], [2.0; 3]).unwrap();
        let tilt = rotate(&M3::identity(), &V3::y(), std::f64::consts::FRAC_PI_4);
        let a = Body {
            rot: tilt,
            w: V3::new(0.0, W_UPRIGHT, 0.0),
            ..still(V3::zeros(), V3::zeros())
        };
        let tip = a.rot.transpose() * needle.support_point(&(a.rot * V3::z()));
        let b = still(V3::new(tip.x, 0.0, tip.z + 0.2 + 0.01), V3::zeros());
        let lower = enclosing_bound(&needle, &a, &plate, &b, &V3::z());
        let overlapping = |t: f64| {
            let at = certify(
                &needle,
                &a.pose_after(t),
                &plate,
                &b.pose_after(t),
                1e-10,
                200,
            );
            matches!(at, Certified::Overlapping { .. })
        };
        let meet = (1..=1000)
            .map(|k| 4.0 * lower * f64::from(k) / 1000.0)
            .find(|&t| overlapping(t));
        assert!(
            meet.is_some_and(|t| t > lower && t < 2.0 * lower),
            "bound {lower}, overlapping from {meet:?}"
        );
    }

    /// Jumps of random length from flat faces spinning alike ([`spinning_alike`]): a contact
    /// proved the first has no overlap before it, and one kept as a [`Candidate`] none in the
    /// interval before it that [`Search::first_contact_after`] proves free.
    #[test]
    fn a_jumps_contact_has_no_overlap_where_it_is_proved_free() {
        let mut rng = crate::rng::Rng::new(29);
        let params = spinning_params();
        let (mut first, mut candidates) = (0, 0);
        for case in 0..3000 {
            let p = [4.0, 10.0][case % 2];
            let x0 = [0.5, 2.0][(case / 2) % 2];
            let q =
                crate::superquadric::Superquadric::with_unit_volume([x0, 1.0, 1.0], [2.0, 2.0, p])
                    .unwrap();
            let mut normal = || V3::new(rng.normal(), rng.normal(), rng.normal());
            let rot = rotate(&M3::identity(), &normal(), 1.0);
            let (dir, w, v) = (normal().normalize(), normal() * 3.0, normal() * 0.2);
            let beyond = rng.range(1e-5, 1e-2);
            let (a, b, overlap) = spinning_alike(&q, rot, w, dir, beyond, v);
            let mut stats = SolverStats::default();
            let mut search = Search::new(&q, &a, &q, &b, &params, &mut stats);
            let Some(d0) = search.dist(0.0, None) else {
                continue;
            };
            let ts = rng.range(0.0, 1.0);
            let (free_from, hit) = match search.speculate(0.0, &d0, ts) {
                Jump::Hit(h) => {
                    first += 1;
                    (0.0, h)
                }
                Jump::Unproved(Some(c)) => {
                    candidates += 1;
                    assert!(c.free_after < c.hit.t, "case {case}: {c:?}");
                    (c.free_after.max(0.0), c.hit)
                }
                _ => continue,
            };
            assert!(overlap(hit.t).abs() < 1e-7, "case {case}: not a contact");
            for k in 0..2000 {
                let t = free_from + (hit.t - free_from) * f64::from(k) / 2000.0;
                assert!(
                    overlap(t) > -1e-9,
                    "case {case}: overlap at {t}, free from {free_from} to the contact at {}",
                    hit.t
                );
            }
        }
        assert!(
            first > 100 && candidates > 100,
            "{first} proved, {candidates} kept"
        );
    }

    /// Newton–Raphson straight from d/|ḋ| ([`Search::direct`]) on bodies spinning alike
    /// ([`spinning_alike`]), curved and flat, from up to half a body length apart, where the gap
    /// may close, open and close again before the estimate: what it returns is a contact,
    /// approached, with no overlap anywhere before it.
    #[test]
    fn a_direct_contact_has_no_overlap_before_it() {
        let mut rng = crate::rng::Rng::new(37);
        let params = spinning_params();
        let mut found = 0;
        for case in 0..3000 {
            let p = [2.0, 4.0, 10.0][case % 3];
            let x0 = [0.25, 4.0][(case / 3) % 2];
            let q =
                crate::superquadric::Superquadric::with_unit_volume([x0, 1.0, 1.0], [2.0, 2.0, p])
                    .unwrap();
            let far = 0.5 * q.bounding_radius();
            let (a, b, overlap) = closing_alike(&mut rng, &q, 1e-4, far);
            let mut stats = SolverStats::default();
            let mut search = Search::new(&q, &a, &q, &b, &params, &mut stats);
            let Some(d0) = search.dist(0.0, None) else {
                continue;
            };
            let slope = search.slope(0.0, &d0);
            if !(d0.d > 0.0 && slope < 0.0) {
                continue;
            }
            let Some(hit) = search.direct(0.0, &d0, slope, 10.0 * d0.d / -slope) else {
                continue;
            };
            found += 1;
            assert_first_contact(case, &search, &hit, overlap);
        }
        assert!(found > 300, "{found} contacts");
    }

    /// What [`Search::direct`] returns from the present: a contact (`overlap`, the exact test of
    /// [`spinning_alike`], zero there), approached, with no overlap anywhere before it.
    fn assert_first_contact<S: Surface>(
        case: usize,
        search: &Search<'_, S>,
        hit: &Hit,
        overlap: impl Fn(f64) -> f64,
    ) {
        assert!(overlap(hit.t).abs() < 1e-7, "case {case}: not a contact");
        assert!(search.closing_at(hit), "case {case}: the bodies part there");
        for k in 0..2000 {
            let t = hit.t * f64::from(k) / 2000.0;
            assert!(
                overlap(t) > -1e-9,
                "case {case}: overlap at {t} before the contact at {}",
                hit.t
            );
        }
    }

    /// [`Search::direct`] as [`predict_from`] calls it at the end of its approach: from the
    /// support points of a separating axis and their gap (a lower bound of the distance, not the
    /// distance), up to a far horizon, on bodies spinning alike ([`spinning_alike`]) from up to
    /// 0.01 apart. What it returns is a contact, approached, with no overlap anywhere before it.
    #[test]
    fn a_direct_contact_from_support_points_has_no_overlap_before_it() {
        let mut rng = crate::rng::Rng::new(41);
        let params = spinning_params();
        let (mut found, mut declined) = (0, 0);
        for case in 0..3000 {
            let p = [2.0, 4.0, 10.0][case % 3];
            let x0 = [0.5, 2.0, 4.0][(case / 3) % 3];
            let q =
                crate::superquadric::Superquadric::with_unit_volume([x0, 1.0, 1.0], [2.0, 2.0, p])
                    .unwrap();
            let (a, b, overlap) = closing_alike(&mut rng, &q, 1e-6, 1e-2);
            let (pa, pb) = (a.pose_after(0.0), b.pose_after(0.0));
            let gap = separating_axis(&q, &pa, &q, &pb);
            let mut stats = SolverStats::default();
            let mut search = Search::new(&q, &a, &q, &b, &params, &mut stats);
            let d0 = gap.support_start(&q, &pa, &q, &pb);
            let slope = search.slope(0.0, &d0);
            if !(d0.d > 0.0 && slope < 0.0) {
                continue;
            }
            let horizon = 4.0;
            let Some(hit) = search.direct(0.0, &d0, slope, horizon) else {
                declined += 1;
                continue;
            };
            found += 1;
            assert_first_contact(case, &search, &hit, overlap);
        }
        assert!(found > 300, "{found} contacts, {declined} declined");
    }
}
