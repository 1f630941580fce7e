//! Distance between two convex bodies (Sec. 2.3): Newton–Raphson on the reduced system (Eqs. 23–25)
//! with the relaxed step (Eqs. 26–29), the initial guess of Sec. 3.2 (Eqs. 49–51), and the
//! steepest descent of Sec. 2.3.2 (Eqs. 16–22) when Newton–Raphson fails.

use nalgebra::{SMatrix, SVector};

use crate::geometry::{M3, Placed, Pose, Surface, V3};
use crate::support_distance::{Certified, certify};

/// Accuracy knobs of the solvers, all scene keys.
#[derive(Clone, Copy, Debug)]
pub struct Tolerances {
    pub nr_tol: f64,
    pub nr_max_iter: u32,
    /// ε_r of Eqs. (27)–(28).
    pub nr_relax: f64,
    pub sd_max_iter: u32,
    pub sd_tol: f64,
}

/// The defaults of the scene keys `nr_tol`, `nr_max_iter`, `nr_relax`, `sd_max_iter`, `sd_tol`.
impl Default for Tolerances {
    fn default() -> Self {
        Tolerances {
            nr_tol: 1e-12,
            nr_max_iter: 50,
            nr_relax: 0.5,
            sd_max_iter: 200,
            sd_tol: 1e-3,
        }
    }
}

/// Counters that make the cost of accuracy visible.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SolverStats {
    /// Pair contact-time searches (Sec. 2.4).
    pub searches: u64,
    pub distance_calls: u64,
    /// Newton–Raphson solves of a contact time (Eqs. 30), converged or not.
    #[serde(default)]
    pub contact_solves: u64,
    pub nr_iterations: u64,
    /// The most Newton–Raphson iterations one distance evaluation took, all its attempts
    /// (warm start, guess, after steepest descent, inside the fallback) together.
    pub nr_iterations_max: u64,
    pub sd_calls: u64,
    /// Solves that failed with no fallback left.
    pub failures: u64,
    /// Contact times for which Newton–Raphson on Eqs. (30) failed and bisection of d(t) was used.
    pub contact_fallbacks: u64,
    /// Distances of needles and plates (aspect above `NEEDLE_ASPECT`, 5) that Gilbert's algorithm
    /// proved overlapping and Newton–Raphson did not resolve (no negative distance of Eqs. 9
    /// that deep): reported as the certified overlap at once, without steepest descent or the
    /// support fallback.
    #[serde(default)]
    pub certified_overlaps: u64,
    /// Distances for which Newton–Raphson and steepest descent failed and the support-function
    /// iteration of [`crate::support_distance`] decided (converged or certified the overlap).
    pub distance_fallbacks: u64,
    /// What the latest failure could not resolve ("distance", "contact time"), for the error
    /// that stops the run.
    #[serde(skip)]
    pub failed: Option<&'static str>,
}

/// A solution of Eqs. (9): closest points, multipliers and the signed distance of Eq. (11).
#[derive(Clone, Copy, Debug)]
pub struct Distance {
    /// Negative for the "negative distance" solution of slightly overlapping bodies.
    pub d: f64,
    pub xa: V3,
    pub xb: V3,
    pub alpha: f64,
    pub beta: f64,
}

/// A warm start: the previous solution, with x_A attached to body A so that it follows A's motion.
#[derive(Clone, Copy, Debug)]
pub struct Guess {
    pub xa_body: V3,
    pub alpha: f64,
    pub beta: f64,
}

impl Distance {
    pub fn guess(&self, pa: &Pose) -> Guess {
        Guess {
            xa_body: pa.to_body(&self.xa),
            alpha: self.alpha,
            beta: self.beta,
        }
    }
}

pub(crate) type M5 = SMatrix<f64, 5, 5>;
pub(crate) type V5 = SVector<f64, 5>;

/// A 3×3 block bordered by two columns and two rows and a 2×2 corner D: the Jacobian of
/// Eqs. (24)–(25) (unknowns Δx_A, Δα, Δβ; D = [0 0; 0 c]) and that of Eqs. (30) for the contact
/// time (unknowns Δx, Δα, Δt; D = [0 ḟ; 0 ġ]):
///
/// ```text
/// [ A   u  w ]
/// [ fᵀ   D   ]
/// [ gᵀ       ]
/// ```
pub(crate) struct Bordered {
    pub a: M3,
    pub u: V3,
    pub w: V3,
    pub f: V3,
    pub g: V3,
    pub d: [[f64; 2]; 2],
}

impl Bordered {
    /// Solves J y = (r, r_f, r_g) through the Schur complement of A, a 2×2 system; a third of
    /// the work of eliminating the 5×5. Without pivoting across the blocks, the error grows with
    /// the conditioning of A and of the complement: when either determinant is below 10⁻³ of
    /// the size of its entries, it falls back to [`solve5`] with pivoting.
    pub fn solve(&self, r: &V3, r_f: f64, r_g: f64) -> Option<V5> {
        let det = self.a.determinant();
        let scale = self.a.abs().max();
        if det.abs() > 1e-3 * scale * scale * scale
            && let Some(inv) = self.a.try_inverse()
        {
            let (y0, yu, yw) = (inv * r, inv * self.u, inv * self.w);
            let d = &self.d;
            let m = [
                [self.f.dot(&yu) - d[0][0], self.f.dot(&yw) - d[0][1]],
                [self.g.dot(&yu) - d[1][0], self.g.dot(&yw) - d[1][1]],
            ];
            let rhs = [self.f.dot(&y0) - r_f, self.g.dot(&y0) - r_g];
            let det2 = m[0][0] * m[1][1] - m[0][1] * m[1][0];
            let size = m[0][0].abs().max(m[0][1].abs()) * m[1][0].abs().max(m[1][1].abs());
            if det2.abs() > 1e-3 * size {
                let da = (rhs[0] * m[1][1] - m[0][1] * rhs[1]) / det2;
                let db = (m[0][0] * rhs[1] - m[1][0] * rhs[0]) / det2;
                let dx = y0 - yu * da - yw * db;
                return Some(V5::new(dx.x, dx.y, dx.z, da, db));
            }
        }
        solve5(&self.full(), &V5::new(r.x, r.y, r.z, r_f, r_g))
    }

    fn full(&self) -> M5 {
        let mut j = M5::zeros();
        j.fixed_view_mut::<3, 3>(0, 0).copy_from(&self.a);
        j.fixed_view_mut::<3, 1>(0, 3).copy_from(&self.u);
        j.fixed_view_mut::<3, 1>(0, 4).copy_from(&self.w);
        j.fixed_view_mut::<1, 3>(3, 0)
            .copy_from(&self.f.transpose());
        j.fixed_view_mut::<1, 3>(4, 0)
            .copy_from(&self.g.transpose());
        for (r, row) in self.d.iter().enumerate() {
            for (c, &x) in row.iter().enumerate() {
                j[(3 + r, 3 + c)] = x;
            }
        }
        j
    }
}

/// J y = rhs by Gaussian elimination with partial pivoting over fixed-size arrays, which the
/// compiler unrolls (nalgebra's generic LU costs a third of a Newton step at this size).
// Indices, not the iterators clippy prefers: see the elimination below.
#[allow(clippy::needless_range_loop)]
pub(crate) fn solve5(j: &M5, rhs: &V5) -> Option<V5> {
    let mut a = [[0.0f64; 6]; 5];
    for r in 0..5 {
        for c in 0..5 {
            a[r][c] = j[(r, c)];
        }
        a[r][5] = rhs[r];
    }
    for k in 0..5 {
        let mut p = k;
        for r in (k + 1)..5 {
            if a[r][k].abs() > a[p][k].abs() {
                p = r;
            }
        }
        if a[p][k] == 0.0 || !a[p][k].is_finite() {
            return None;
        }
        a.swap(k, p);
        let inv = 1.0 / a[k][k];
        // Indices, not iterators: `skip` and `zip` over the rows kept the loops from unrolling
        // (1,600 instructions a solve in a Newton step of the contact time, now 500).
        for r in k + 1..5 {
            let f = a[r][k] * inv;
            for c in k..6 {
                a[r][c] -= f * a[k][c];
            }
        }
    }
    let mut y = V5::zeros();
    for k in (0..5).rev() {
        let mut acc = a[k][5];
        for c in (k + 1)..5 {
            acc -= a[k][c] * y[c];
        }
        y[k] = acc / a[k][k];
    }
    Some(y)
}

/// Signed distance between A and B, or `None` (counted in `stats.failures`) when every method fails.
pub fn distance<S: Surface>(
    sa: &S,
    pa: &Pose,
    sb: &S,
    pb: &Pose,
    warm: Option<&Guess>,
    tol: &Tolerances,
    stats: &mut SolverStats,
) -> Option<Distance> {
    stats.distance_calls += 1;
    let iterations = stats.nr_iterations;
    let d = solve_distance(sa, pa, sb, pb, warm, tol, stats);
    stats.nr_iterations_max = stats
        .nr_iterations_max
        .max(stats.nr_iterations - iterations);
    d
}

/// [`distance`] without the counting of calls and iterations per call.
fn solve_distance<S: Surface>(
    sa: &S,
    pa: &Pose,
    sb: &S,
    pb: &Pose,
    warm: Option<&Guess>,
    tol: &Tolerances,
    stats: &mut SolverStats,
) -> Option<Distance> {
    let l = sa.semi_axes().min().min(sb.semi_axes().min());
    let gilbert_start = poor_guess(sa) || poor_guess(sb);
    if let Some(g) = warm {
        let xa = pa.to_lab(&g.xa_body);
        let warm_tol = Tolerances {
            nr_max_iter: if gilbert_start {
                tol.nr_max_iter.min(WARM_ITERATIONS)
            } else {
                tol.nr_max_iter
            },
            ..*tol
        };
        if let Some(d) =
            newton::<_, PLAIN>(sa, pa, sb, pb, xa, g.alpha, g.beta, l, &warm_tol, stats)
        {
            return Some(d);
        }
    }
    let (xa, xb, overlap) = if gilbert_start {
        gilbert_guess(sa, pa, sb, pb, l)
    } else {
        let (xa, xb) = initial_guess(sa, pa, sb, pb);
        (xa, xb, None)
    };
    let (alpha, beta) = multipliers_guess(sa, pa, sb, pb, &xa, &xb);
    if let Some(d) = newton::<_, PLAIN>(sa, pa, sb, pb, xa, alpha, beta, l, tol, stats) {
        return Some(d);
    }
    if let Some(certified) = overlap.filter(|_| elongated(sa) || elongated(sb)) {
        // Proved overlapping, and too deep for the negative distance of Eqs. (9): neither the
        // steepest descent nor the support fallback would prove more.
        stats.certified_overlaps += 1;
        let (inside, lower) = certified;
        return Some(overlap_distance(inside, lower, l, tol));
    }
    stats.sd_calls += 1;
    let (xa, xb) = steepest_descent(sa, pa, sb, pb, tol);
    let (alpha, beta) = multipliers_guess(sa, pa, sb, pb, &xa, &xb);
    if let Some(d) = newton::<_, PLAIN>(sa, pa, sb, pb, xa, alpha, beta, l, tol, stats) {
        return Some(d);
    }
    if let Some(d) = support_fallback(sa, pa, sb, pb, l, tol, stats) {
        stats.distance_fallbacks += 1;
        return Some(d);
    }
    stats.failures += 1;
    stats.failed = Some("distance");
    None
}

/// Iterations of Gilbert's algorithm allowed in [`support_fallback`]; it converges linearly on
/// curved bodies, and a few hundred suffice for X0 = 0.1 face to face.
const SUPPORT_MAX_ITER: u32 = 20_000;

/// The globally convergent fallback: Gilbert's algorithm ([`certify`]) to 10⁻³ of the smallest
/// semi-axis, Newton–Raphson from its support points (which it brings close to the closest
/// points), [`PLAIN`] and then [`BACKTRACKING`], and, should that fail too, Gilbert's algorithm
/// to the Newton tolerance. Bodies it proves overlapping get a negative distance (a lower bound
/// on the signed distance, without closest points); `None` only if nothing is proved.
fn support_fallback<S: Surface>(
    sa: &S,
    pa: &Pose,
    sb: &S,
    pb: &Pose,
    l: f64,
    tol: &Tolerances,
    stats: &mut SolverStats,
) -> Option<Distance> {
    let coarse = certify(sa, pa, sb, pb, 1e-3 * l, SUPPORT_MAX_ITER);
    // Touching bodies leave the bounds undecided, but the support points along the best axis
    // are then nearly the contact points.
    if let Certified::Apart { xa, xb, .. } | Certified::Undecided { xa, xb, .. } = coarse {
        let (alpha, beta) = multipliers_guess(sa, pa, sb, pb, &xa, &xb);
        if let Some(d) = newton::<_, PLAIN>(sa, pa, sb, pb, xa, alpha, beta, l, tol, stats) {
            return Some(d);
        }
        if let Some(d) = newton::<_, BACKTRACKING>(sa, pa, sb, pb, xa, alpha, beta, l, tol, stats) {
            return Some(d);
        }
    }
    let fine = match coarse {
        Certified::Apart { .. } | Certified::Undecided { .. } => {
            certify(sa, pa, sb, pb, tol.nr_tol * l, SUPPORT_MAX_ITER)
        }
        overlap => overlap,
    };
    match fine {
        Certified::Apart { lower, xa, xb, .. } => {
            let (alpha, beta) = multipliers_guess(sa, pa, sb, pb, &xa, &xb);
            Some(Distance {
                d: lower,
                xa,
                xb,
                alpha,
                beta,
            })
        }
        Certified::Overlapping { inside, lower } => Some(overlap_distance(inside, lower, l, tol)),
        Certified::Undecided { .. } => None,
    }
}

/// The distance reported for bodies [`certify`] proved overlapping: its negative lower bound
/// `lower` (−nr_tol·l where it has none), with the point `inside` both as either closest point.
fn overlap_distance(inside: V3, lower: f64, l: f64, tol: &Tolerances) -> Distance {
    Distance {
        d: if lower.is_finite() && lower < 0.0 {
            lower
        } else {
            -tol.nr_tol * l
        },
        xa: inside,
        xb: inside,
        alpha: 1.0,
        beta: 0.0,
    }
}

/// Beyond this ratio of its longest to its shortest semi-axis a body's guess of Sec. 3.2 (Eq. 51)
/// is poor (the paper: good for 0.2 < X0 < 5). From it, Newton–Raphson took 13 (X0 = 10) and 23
/// (X0 = 0.1) iterations on average for pairs within 5 % of contact, 5–15 % of them never
/// converged (steepest descent, then the support fallback); from [`gilbert_guess`], 5, all
/// converging (MEASUREMENTS.md, "Hard shapes"). Between 3 and 5 too: ellipsoids X0 = 4, 5, 0.25
/// and 0.2 (N 400, φ 0.3) took 11.1, 16.4, 8.8 and 9.8 iterations a distance on linked cells
/// from the guess, 45–154 support fallbacks in 20,000 collisions, and 4, 16, 2 and 3 % more
/// instructions than from Gilbert's start, which took 8.7, 10.0, 8.1 and 8.5 and fell back
/// never (MEASUREMENTS.md, "A distance the support fallback gave up on; Gilbert's start from
/// aspect 3; …").
const GUESS_ASPECT: f64 = 3.0;

/// Newton–Raphson iterations a warm start (the previous solution along the trajectory) is given
/// where the guess is poor ([`poor_guess`]): from inside its basin it converges in a few; past
/// this it is drifting (towards α → 0 and a stationary point that is not the distance) and the
/// cold start is cheaper than the rest of `nr_max_iter`.
const WARM_ITERATIONS: u32 = 8;

/// How close to the distance (in units of the smallest semi-axis) Gilbert's algorithm brings
/// the start of Newton–Raphson in [`gilbert_guess`], and the iterations it may take for it.
const GILBERT_START_TOL: f64 = 0.3;
const GILBERT_START_ITER: u32 = 1_000;

/// The ratio of a body's longest to its shortest semi-axis.
fn aspect<S: Surface>(s: &S) -> f64 {
    let semi = s.semi_axes();
    semi.max() / semi.min()
}

/// Whether the guess of Sec. 3.2 is poor for `s`: its aspect ratio is above [`GUESS_ASPECT`].
fn poor_guess<S: Surface>(s: &S) -> bool {
    aspect(s) > GUESS_ASPECT
}

/// Needles and plates: bodies of aspect ratio above [`NEEDLE_ASPECT`]. An overlap Gilbert's
/// algorithm proves is reported at once where Newton–Raphson does not resolve it (steepest
/// descent would not either), and the contact search's damped axis ascent stalls near the line
/// of centres, so it takes the needles' axis (`contact::elongated_axis`).
pub(crate) fn elongated<S: Surface>(s: &S) -> bool {
    aspect(s) > NEEDLE_ASPECT
}

/// The aspect ratio above which a body is [`elongated`]. Between [`GUESS_ASPECT`] and this,
/// steepest descent still resolves the overlaps of 5 % that Newton–Raphson from the guess does
/// not (X0 = 4.7: `sign_matches_perram_wertheim`); and the ascent, four lanes at a time, still
/// costs less than the needles' axes on neighbour lists (X0 = 5, N 400, φ 0.3: 302 against
/// 329 M instructions), though not on linked cells (1,166 against 844 M).
const NEEDLE_ASPECT: f64 = 5.0;

/// The start of Newton–Raphson where the guess is poor: the support points along the best
/// separating axis Gilbert's algorithm finds ([`certify`]) within [`GILBERT_START_TOL`] of the
/// distance, which lie near the closest points whatever the bodies' shapes; the guess of
/// Sec. 3.2 where the bodies overlap, with what proved the overlap (a point inside both and a
/// lower bound on the signed distance).
fn gilbert_guess<S: Surface>(
    sa: &S,
    pa: &Pose,
    sb: &S,
    pb: &Pose,
    l: f64,
) -> (V3, V3, Option<(V3, f64)>) {
    match certify(sa, pa, sb, pb, GILBERT_START_TOL * l, GILBERT_START_ITER) {
        Certified::Apart { xa, xb, .. } | Certified::Undecided { xa, xb, .. } => (xa, xb, None),
        Certified::Overlapping { inside, lower } => {
            let (xa, xb) = initial_guess(sa, pa, sb, pb);
            (xa, xb, Some((inside, lower)))
        }
    }
}

/// Guess of Sec. 3.2: the line of centres, seen in each body frame, is scaled by the semi-axes
/// (Eqs. 49–51) and intersected with the surface. Exact for spheres, good for 0.2 < X0 < 5.
pub fn initial_guess<S: Surface>(sa: &S, pa: &Pose, sb: &S, pb: &Pose) -> (V3, V3) {
    let r_ab = pa.r - pb.r;
    let va = -(pa.rot * r_ab); // Eq. (49a)
    let vb = pb.rot * r_ab; // Eq. (49b)
    // The normalisation 1/√(a²+b²+c²) of Eq. (51) drops out of a ray direction.
    let xa = pa.to_lab(&sa.ray_point(&sa.semi_axes().component_mul(&va)));
    let xb = pb.to_lab(&sb.ray_point(&sb.semi_axes().component_mul(&vb)));
    (xa, xb)
}

/// α = √(‖f_x‖/‖g_x‖) from the modulus of Eq. (9a); β from the projection of Eq. (9d).
pub(crate) fn multipliers_guess<S: Surface>(
    sa: &S,
    pa: &Pose,
    sb: &S,
    pb: &Pose,
    xa: &V3,
    xb: &V3,
) -> (f64, f64) {
    let fx = sa.place(pa).grad(xa);
    let gx = sb.place(pb).grad(xb);
    let alpha = (fx.norm() / gx.norm()).sqrt();
    let beta = (xb - xa).dot(&fx) / fx.norm_squared();
    (alpha, beta)
}

/// How [`newton`] takes its steps: as Eq. (29) damps them, or ([`BACKTRACKING`]) only where
/// a step lowers the residual of Eqs. (23), halved until it does ([`MAX_BACKTRACKS`] times at
/// most), the last resort of [`support_fallback`]. Two long, flat sides at a small angle
/// (superquadrics [2, 2, 10] whose generators meet at 1.8°) put Gilbert's support points 0.3 of
/// a semi-axis from the closest points along the sides, though within 3·10⁻⁷ of the distance;
/// the plain steps from there run along the nearly singular direction onto the ends' powers of
/// 10 and off the bodies.
const PLAIN: bool = false;
/// See [`PLAIN`].
const BACKTRACKING: bool = true;

/// Halvings of a step that a [`BACKTRACKING`] [`newton`] tries before it gives up.
const MAX_BACKTRACKS: u32 = 40;

/// Newton–Raphson on Eqs. (23) with the Jacobian of Eqs. (24)–(25) and the damping of Eq. (29),
/// its steps taken as `BACKTRACK` says ([`PLAIN`] or [`BACKTRACKING`]).
#[allow(clippy::too_many_arguments)]
fn newton<S: Surface, const BACKTRACK: bool>(
    sa: &S,
    pa: &Pose,
    sb: &S,
    pb: &Pose,
    mut xa: V3,
    mut alpha: f64,
    mut beta: f64,
    l: f64,
    tol: &Tolerances,
    stats: &mut SolverStats,
) -> Option<Distance> {
    let eye = M3::identity();
    let (qa, qb) = (sa.place(pa), sb.place(pb));
    for _ in 0..tol.nr_max_iter {
        stats.nr_iterations += 1;
        let ea = qa.eval(&xa);
        let fx = ea.grad;
        let xb = xa + fx * beta;
        let eb = qb.eval(&xb);
        let gx = eb.grad;
        let a2 = alpha * alpha;
        let f1 = fx + gx * a2;
        let fxn = fx.norm();
        if f1.norm() <= tol.nr_tol * fxn && ea.f.abs() <= tol.nr_tol && eb.f.abs() <= tol.nr_tol {
            return accept(&qa, &qb, xa, xb, alpha, beta, l);
        }
        let dxb = eye + ea.hess * beta; // ∂x_B/∂x_A
        let jacobian = Bordered {
            a: ea.hess + eb.hess * dxb * a2,
            u: gx * (2.0 * alpha),
            w: eb.hess * fx * a2,
            f: fx,
            g: dxb.transpose() * gx,
            d: [[0.0, 0.0], [0.0, gx.dot(&fx)]],
        };
        let step = jacobian.solve(&(-f1), -ea.f, -eb.f)?;
        let (dalpha, dbeta) = (step[3], step[4]);
        // Eq. (29): bound the relative change of α² (Eq. 27) and the change of the gap β‖f_x‖ (Eq. 28).
        let mut xi: f64 = 1.0;
        let da2 = (2.0 * alpha * dalpha).abs();
        if da2 > tol.nr_relax * a2 {
            xi = xi.min(tol.nr_relax * a2 / da2);
        }
        let dgap = dbeta.abs() * fxn;
        if dgap > tol.nr_relax * l {
            xi = xi.min(tol.nr_relax * l / dgap);
        }
        // Not in the paper: nor may x_A move by more than l in one step. Along the flat sides of
        // a high exponent the Jacobian is nearly singular, and an undamped step there leaves the
        // body by orders of magnitude (f, a power 10 of the coordinates, then overflows).
        let dxa = step.fixed_rows::<3>(0).into_owned();
        let dx = dxa.norm();
        if dx > l {
            xi = xi.min(l / dx);
        }
        if BACKTRACK {
            // The residual of Eqs. (23), its first row relative to |f_x| as the test above takes it.
            let merit =
                |f1: &V3, fxn: f64, fa: f64, fb: f64| (f1.norm() / fxn).powi(2) + fa * fa + fb * fb;
            let residual = |xa: &V3, alpha: f64, beta: f64| {
                let ea = qa.eval(xa);
                let eb = qb.eval(&(xa + ea.grad * beta));
                let f1 = ea.grad + eb.grad * (alpha * alpha);
                merit(&f1, ea.grad.norm(), ea.f, eb.f)
            };
            let now = merit(&f1, fxn, ea.f, eb.f);
            let mut halvings = 0;
            // A NaN residual (a step off the bodies' powers) is no decrease either.
            while residual(
                &(xa + dxa * xi),
                (alpha + xi * dalpha).abs(),
                beta + xi * dbeta,
            )
            .partial_cmp(&now)
                != Some(std::cmp::Ordering::Less)
            {
                halvings += 1;
                if halvings > MAX_BACKTRACKS {
                    return None;
                }
                xi *= 0.5;
            }
        }
        xa += dxa * xi;
        alpha = (alpha + xi * dalpha).abs();
        beta += xi * dbeta;
        if !(xa.iter().all(|v| v.is_finite()) && alpha.is_finite() && beta.is_finite())
            || alpha == 0.0
        {
            return None;
        }
    }
    None
}

/// Rejects spurious roots of Eqs. (9) (e.g. the farthest pair of points, Fig. 1a): for a true
/// (negative) distance each closest point lies outside (inside) the other body.
fn accept<P: Placed>(
    qa: &P,
    qb: &P,
    xa: V3,
    xb: V3,
    alpha: f64,
    beta: f64,
    l: f64,
) -> Option<Distance> {
    let gap = (xb - xa).norm();
    let d = if beta < 0.0 { -gap } else { gap };
    // Below this the sign tests are dominated by rounding and both bodies touch anyway.
    if gap > 1e-6 * l {
        let ga = qb.f(&xa);
        let fb = qa.f(&xb);
        if (beta > 0.0) != (ga > 0.0) || (beta > 0.0) != (fb > 0.0) {
            return None;
        }
        if beta < 0.0 && gap > l {
            return None;
        }
    }
    Some(Distance {
        d,
        xa,
        xb,
        alpha,
        beta,
    })
}

/// Steepest descent of D = ‖x_A − x_B‖² on the two surfaces (Sec. 2.3.2, Eqs. 16–22), from the
/// intersections of the line of centres with the surfaces (Fig. 3a).
pub fn steepest_descent<S: Surface>(
    sa: &S,
    pa: &Pose,
    sb: &S,
    pb: &Pose,
    tol: &Tolerances,
) -> (V3, V3) {
    // λ_SD of Eq. (20); with α_SD = 1/2 a step moves each point half of the tangential separation.
    const LAMBDA_SD: f64 = 0.5;
    let dir = pb.r - pa.r;
    let mut xa = pa.to_lab(&sa.ray_point(&(pa.rot * dir)));
    let mut xb = pb.to_lab(&sb.ray_point(&(pb.rot * -dir)));
    let (qa, qb) = (sa.place(pa), sb.place(pb));
    for _ in 0..tol.sd_max_iter {
        let na = qa.grad(&xa).normalize();
        let nb = qb.grad(&xb).normalize();
        let h = xa - xb; // Eq. (17), h_A = −h_B
        let hn = h.norm();
        if hn == 0.0
            || (na.cross(&h).norm() < tol.sd_tol * hn && nb.cross(&h).norm() < tol.sd_tol * hn)
        {
            break;
        }
        let ha = h - na * h.dot(&na); // Eq. (19)
        let hb = -h + nb * h.dot(&nb);
        xa = project(&qa, &(xa - ha * LAMBDA_SD)); // Eqs. (20)–(22)
        xb = project(&qb, &(xb - hb * LAMBDA_SD));
    }
    (xa, xb)
}

/// Eq. (22): moves x along the local normal onto the surface by a one-dimensional Newton–Raphson.
fn project<P: Placed>(q: &P, x: &V3) -> V3 {
    let n = q.grad(x);
    let mut xi = 0.0;
    for _ in 0..30 {
        let y = x + n * xi;
        let f = q.f(&y);
        if f.abs() < 1e-15 {
            break;
        }
        let df = q.grad(&y).dot(&n);
        if df == 0.0 {
            break;
        }
        xi -= f / df;
    }
    x + n * xi
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ellipsoid::Ellipsoid;
    use crate::rigid::rotate;
    use crate::superquadric::Superquadric;

    proptest::proptest! {
        #[test]
        fn the_bordered_solve_matches_elimination_with_pivoting(
            a in proptest::array::uniform9(-3.0f64..3.0),
            border in proptest::array::uniform12(-3.0f64..3.0),
            corner in proptest::array::uniform4(-3.0f64..3.0),
            zeros in proptest::array::uniform3(proptest::bool::ANY),
            r in proptest::array::uniform5(-3.0f64..3.0),
        ) {
            let v = |k: usize| V3::new(border[k], border[k + 1], border[k + 2]);
            // The corners of the distance and of the contact time have zeros: some here too.
            let at = |k: usize| if k < 3 && zeros[k] { 0.0 } else { corner[k] };
            let d = [[at(0), at(1)], [at(2), at(3)]];
            let j = Bordered { a: M3::from_row_slice(&a), u: v(0), w: v(3), f: v(6), g: v(9), d };
            let rhs = V5::from_row_slice(&r);
            let full = j.full();
            match (j.solve(&V3::new(r[0], r[1], r[2]), r[3], r[4]), solve5(&full, &rhs)) {
                (Some(y), Some(_)) => {
                    // Both solve the same system: judge by the residual, scaled by the condition.
                    let scale = full.abs().max() * y.abs().max() + rhs.abs().max();
                    proptest::prop_assert!((full * y - rhs).abs().max() <= 1e-9 * scale, "{}", (full * y - rhs).abs().max());
                }
                (None, None) => {}
                (mine, pivoted) => proptest::prop_assert!(mine.is_some() || pivoted.is_none(), "{:?} vs {:?}", mine, pivoted),
            }
        }
    }

    /// The uniaxial ellipsoid of aspect ratio `x0` and volume π/6.
    fn unit_ellipsoid(x0: f64) -> Ellipsoid {
        let b = 0.5 / f64::cbrt(x0);
        Ellipsoid::new(x0 * b, b, b)
    }

    /// Two copies of `e` in random orientations, apart along a random direction by up to 5 %
    /// more than where they touch.
    fn near_contact(e: &Ellipsoid, rng: &mut crate::rng::Rng) -> (Pose, Pose) {
        let mut rot = || {
            let axis = V3::new(rng.normal(), rng.normal(), rng.normal());
            rotate(&M3::identity(), &axis, 1.0)
        };
        let (ra, rb) = (rot(), rot());
        let dir = V3::new(rng.normal(), rng.normal(), rng.normal());
        // The contact scale is homogeneous of degree one in the separation.
        let touching = dir / crate::pw::contact_scale(e, &ra, e, &rb, &dir);
        let pa = Pose {
            r: V3::zeros(),
            rot: ra,
        };
        let pb = Pose {
            r: touching * (1.0 + 0.05 * rng.uniform() + 1e-6),
            rot: rb,
        };
        (pa, pb)
    }

    /// Needles and plates (X0 = 10, 4, 0.25 and 0.1) within 5 % of contact, from a cold start:
    /// Newton–Raphson from Gilbert's support points converges without steepest descent or the
    /// support fallback, to the distance Gilbert's algorithm brackets on its own to 1e-10.
    #[test]
    fn elongated_bodies_converge_from_a_cold_start_to_the_certified_distance() {
        let mut rng = crate::rng::Rng::new(17);
        for x0 in [10.0, 4.0, 0.25, 0.1] {
            let e = unit_ellipsoid(x0);
            let l = e.s.min();
            let mut stats = SolverStats::default();
            for _ in 0..400 {
                let (pa, pb) = near_contact(&e, &mut rng);
                let d = distance(&e, &pa, &e, &pb, None, &Tolerances::default(), &mut stats)
                    .expect("a distance");
                match certify(&e, &pa, &e, &pb, 1e-10 * l, 1_000_000) {
                    Certified::Apart { lower, upper, .. } => assert!(
                        d.d >= lower - 1e-9 * l && d.d <= upper + 1e-9 * l,
                        "X0 {x0}: {} not in [{lower}, {upper}]",
                        d.d
                    ),
                    other => panic!("X0 {x0}: apart bodies not certified: {other:?}"),
                }
            }
            assert_eq!(
                (stats.sd_calls, stats.distance_fallbacks, stats.failures),
                (0, 0, 0),
                "X0 {x0}"
            );
            // The guess of Sec. 3.2 takes 6.9 (X0 = 4) and 7.2 (X0 = 0.25) on average.
            assert!(
                stats.nr_iterations <= 6 * 400,
                "X0 {x0}: {} Newton iterations for 400 distances",
                stats.nr_iterations
            );
        }
    }

    /// Needles and plates pushed into each other (centres at 40–90 % of where they touch, as
    /// where the contact search's jumps land): too deep for the negative distance of Eqs. (9),
    /// each is the overlap Gilbert's algorithm proved, at once: no steepest descent, no support
    /// fallback, a negative distance (a support gap: a lower bound) and a point inside both.
    #[test]
    fn deep_overlaps_of_elongated_bodies_are_certified_without_the_fallback() {
        let mut rng = crate::rng::Rng::new(29);
        for x0 in [10.0, 0.1] {
            let e = unit_ellipsoid(x0);
            let (mut stats, mut before) = (SolverStats::default(), 0);
            for _ in 0..200 {
                let (pa, mut pb) = near_contact(&e, &mut rng);
                pb.r *= 0.4 + 0.5 * rng.uniform();
                let d = distance(&e, &pa, &e, &pb, None, &Tolerances::default(), &mut stats)
                    .expect("a distance");
                // The Perram–Wertheim scale, an independent test: below 1 they overlap.
                assert!(crate::pw::contact_scale(&e, &pa.rot, &e, &pb.rot, &(pb.r - pa.r)) < 1.0);
                assert!(d.d < 0.0, "X0 {x0}: overlapping bodies {} apart", d.d);
                // A support gap is no lower than −|r_B − r_A| − L_A − L_B.
                assert!(
                    d.d >= -4.0 * e.s.max(),
                    "X0 {x0}: {} below every support gap",
                    d.d
                );
                let certified = stats.certified_overlaps;
                if certified > before {
                    let (qa, qb) = (e.place(&pa), e.place(&pb));
                    assert!(
                        qa.f(&d.xa) < 0.0 && qb.f(&d.xa) < 0.0,
                        "X0 {x0}: not inside both"
                    );
                }
                before = certified;
            }
            assert_eq!(
                (stats.sd_calls, stats.distance_fallbacks, stats.failures),
                (0, 0, 0),
                "X0 {x0}"
            );
            assert!(stats.certified_overlaps >= 40, "X0 {x0}: {stats:?}");
        }
    }

    /// Superquadrics [2, 2, 10], X0 = 2, whose long flat sides (straight along the exponent 10's
    /// axis) face each other with their generators 1.8° apart, 2.3 % of a semi-axis apart: a pair
    /// met by a run (φ 0.256, N 2048, seed 27) where Newton–Raphson from every start, steepest
    /// descent and Gilbert's algorithm to the Newton tolerance all failed, and the run with
    /// them. The distance lies in Gilbert's certified bracket.
    #[test]
    fn flat_sides_at_a_small_angle_are_resolved() {
        let s = [0.7157430563396469, 0.3578715281698234, 0.3578715281698234];
        let q = Superquadric::new(s, [2.0, 2.0, 10.0]).expect("a valid superquadric");
        let pose = |r: [f64; 3], rot: [f64; 9]| Pose {
            r: V3::from(r),
            rot: M3::from_column_slice(&rot),
        };
        let pa = pose(
            [13.755330898251566, 10.704561072247142, 2.9994006397323516],
            [
                -0.5074288610740968,
                0.8590681288378142,
                0.06721533280540695,
                0.6449314819558349,
                0.32689439220812777,
                0.6907991313870693,
                0.5714712018389864,
                0.39388070066706166,
                -0.719915730562077,
            ],
        );
        let pb = pose(
            [14.128727883563208, 11.613600201766086, 3.7424833412409417],
            [
                -0.5412163708482197,
                -0.8367814968992119,
                0.08295520702762846,
                -0.5572248409247624,
                0.430778515842182,
                0.7098805159639054,
                -0.6297502017326043,
                0.33797425454599556,
                -0.6994198214819359,
            ],
        );
        let l = s[1];
        let mut stats = SolverStats::default();
        let d = distance(&q, &pa, &q, &pb, None, &Tolerances::default(), &mut stats)
            .expect("the distance resolves");
        assert_eq!(stats.failures, 0);
        let Certified::Apart { lower, upper, .. } = certify(&q, &pa, &q, &pb, 1e-6 * l, 1_000_000)
        else {
            panic!("apart bodies not certified")
        };
        assert!(
            d.d >= lower && d.d <= upper,
            "{} not in [{lower}, {upper}]",
            d.d
        );
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
        /// The class of the pair above: superquadrics [2, 2, p] whose flat sides (straight along
        /// the axis of exponent p) face each other, their generators up to 6° apart, within 5 % of
        /// contact. Every distance resolves, within Gilbert's certified bracket.
        #[test]
        fn flat_sides_at_small_angles_resolve(
            p in 4.0f64..12.0,
            x0 in 1.0f64..3.0,
            turn in proptest::array::uniform4(-1.0f64..1.0),
            tilt in proptest::array::uniform3(-1.0f64..1.0),
            angle in 0.0f64..0.1,
            around in 0.0f64..std::f64::consts::TAU,
            gap in 0.0f64..0.05,
        ) {
            let b = 0.5 / x0.cbrt();
            let s = [x0 * b, b, b];
            let q = Superquadric::new(s, [2.0, 2.0, p]).expect("a valid superquadric");
            let ra = rotate(&M3::identity(), &V3::new(turn[0], turn[1], turn[2]), 3.0 * turn[3]);
            let rb = rotate(&ra, &V3::new(tilt[0], tilt[1], tilt[2]), angle);
            // Across A's straight sides: a direction in its x–y plane, in the lab.
            let dir = ra.transpose() * V3::new(around.cos(), around.sin(), 0.0);
            let touching = dir / crate::scale::contact_scale(&q, &ra, &q, &rb, &dir);
            let pa = Pose { r: V3::zeros(), rot: ra };
            let pb = Pose { r: touching * (1.0 + gap + 1e-6), rot: rb };
            let l = b;
            let mut stats = SolverStats::default();
            let d = support_fallback(&q, &pa, &q, &pb, l, &Tolerances::default(), &mut stats);
            proptest::prop_assert!(d.is_some(), "unresolved: {:?}", stats);
            let d = d.expect("resolved").d;
            let (lower, upper) = match certify(&q, &pa, &q, &pb, 1e-7 * l, 2_000_000) {
                Certified::Apart { lower, upper, .. } | Certified::Undecided { lower, upper, .. } => (lower, upper),
                Certified::Overlapping { .. } => panic!("apart bodies proved overlapping"),
            };
            proptest::prop_assert!(d >= lower - 1e-9 * l && d <= upper + 1e-9 * l, "{} not in [{}, {}]", d, lower, upper);
        }
    }

    /// The support fallback on its own (what a distance comes to when every Newton start
    /// fails): plates near contact, resolved to within Gilbert's certified bracket.
    #[test]
    fn the_support_fallback_finds_the_certified_distance() {
        let mut rng = crate::rng::Rng::new(23);
        let e = unit_ellipsoid(0.1);
        let l = e.s.min();
        let mut stats = SolverStats::default();
        for _ in 0..100 {
            let (pa, pb) = near_contact(&e, &mut rng);
            let d = support_fallback(&e, &pa, &e, &pb, l, &Tolerances::default(), &mut stats)
                .expect("the fallback resolves apart bodies");
            let Certified::Apart { lower, upper, .. } =
                certify(&e, &pa, &e, &pb, 1e-10 * l, 1_000_000)
            else {
                panic!("apart bodies not certified")
            };
            assert!(
                d.d >= lower - 1e-9 * l && d.d <= upper + 1e-9 * l,
                "{} not in [{lower}, {upper}]",
                d.d
            );
        }
    }

    #[test]
    fn solve5_matches_lu() {
        let j = M5::from_fn(|r, c| ((r * 7 + c * 3) % 5) as f64 + if r == c { 4.0 } else { 0.5 });
        let rhs = V5::new(1.0, -2.0, 0.5, 3.0, -1.0);
        let y = solve5(&j, &rhs).unwrap();
        assert!((j * y - rhs).norm() < 1e-12);
    }

    #[test]
    fn spheres_give_centre_distance_minus_diameter() {
        let e = Ellipsoid::new(0.5, 0.5, 0.5);
        let pa = Pose {
            r: V3::zeros(),
            rot: M3::identity(),
        };
        let mut st = SolverStats::default();
        for &x in &[1.3, 1.0 + 1e-9, 1.0 - 1e-9, 0.9] {
            let pb = Pose {
                r: V3::new(x, 0.2, -0.1),
                rot: rotate(&M3::identity(), &V3::new(1.0, 2.0, 3.0), 0.7),
            };
            let d = distance(&e, &pa, &e, &pb, None, &Tolerances::default(), &mut st).unwrap();
            assert!(
                (d.d - (pb.r.norm() - 1.0)).abs() < 1e-12,
                "{} vs {}",
                d.d,
                pb.r.norm() - 1.0
            );
        }
        assert_eq!(st.failures, 0);
    }

    #[test]
    fn steepest_descent_then_newton_agree_with_newton() {
        let e = Ellipsoid::new(1.2, 0.3, 0.3);
        let pa = Pose {
            r: V3::zeros(),
            rot: rotate(&M3::identity(), &V3::new(0.0, 0.0, 1.0), 0.4),
        };
        let pb = Pose {
            r: V3::new(1.5, 1.6, 0.3),
            rot: rotate(&M3::identity(), &V3::new(1.0, 0.0, 1.0), 1.1),
        };
        let mut st = SolverStats::default();
        let d = distance(&e, &pa, &e, &pb, None, &Tolerances::default(), &mut st).unwrap();
        let (xa, xb) = steepest_descent(
            &e,
            &pa,
            &e,
            &pb,
            &Tolerances {
                sd_max_iter: 5000,
                sd_tol: 1e-10,
                ..Tolerances::default()
            },
        );
        assert!(
            ((xa - xb).norm() - d.d).abs() < 1e-6,
            "{} vs {}",
            (xa - xb).norm(),
            d.d
        );
    }
}
