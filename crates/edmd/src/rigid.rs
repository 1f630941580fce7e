//! Free motion of a rigid body with an isotropic inertia tensor (Eqs. 3–6) and the collision rule (Eqs. 40–41).

use crate::geometry::{
    M3, MOST_DENOMINATOR, Pose, SupportModulus, Surface, V3, lcm_at_most, pow, root_above,
    whole_power,
};

/// State of one body at its own time `t` (bodies are advanced lazily, only when an event needs them).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[repr(C, align(64))]
pub struct Body {
    // Position, velocity and time first, aligned: the sphere path reads only them, one cache line.
    pub r: V3,
    pub v: V3,
    pub t: f64,
    /// Orientational matrix R, rows = body axes (Eq. 1).
    pub rot: M3,
    /// Angular velocity w (lab frame).
    pub w: V3,
}

/// R(t) = R(0)(I + M), M = −sin(wt)/w Ω + (1 − cos wt)/w² Ω², Ω x = w × x (Eqs. 3–5).
///
/// Row by row: a row uᵀ of R(0) becomes (u + Mᵀu)ᵀ, and Ωᵀ = −Ω gives
/// Mᵀu = sin(wt)/w (w × u) + (1 − cos wt)/w² w × (w × u): two cross products a row instead of
/// the two 3 × 3 products of R(0)(I + M), in a rotation that every candidate of a contact
/// search pays (3.5 % of τ_c, ellipsoids X0 = 2, φ 0.5, N 256). Its sine and cosine are
/// `libm::sincos`'s (fdlibm's, under an ulp), cheaper than the C library's (MEASUREMENTS.md, "The
/// turns' sines and cosines"), by `sin_cos`, and [`crate::first_step`] computes them four at a
/// time to the same bits.
pub fn rotate(rot: &M3, w: &V3, t: f64) -> M3 {
    let wn = w.norm();
    if wn == 0.0 {
        return *rot;
    }
    turn(rot, wn, &turn_axes(rot, w), t)
}

/// w × u and w × (w × u) for the rows u of `rot`: what Eq. (5)'s turn of `rot` by w does not
/// take from the time.
fn turn_axes(rot: &M3, w: &V3) -> [(V3, V3); 3] {
    [0, 1, 2].map(|k| {
        let wu = w.cross(&rot.row(k).transpose());
        (wu, w.cross(&wu))
    })
}

/// fdlibm's coefficients (Sun, 1993; k_sin.c and k_cos.c), by their bits: S1–S6 and C1–C6.
pub(crate) const SIN_KERNEL: [u64; 6] = [
    0xbfc5_5555_5555_5549,
    0x3f81_1111_1110_f8a6,
    0xbf2a_01a0_19c1_61d5,
    0x3ec7_1de3_57b1_fe7d,
    0xbe5a_e5e6_8a2b_9ceb,
    0x3de5_d93a_5acf_d57c,
];
pub(crate) const COS_KERNEL: [u64; 6] = [
    0x3fa5_5555_5555_554c,
    0xbf56_c16c_16c1_5177,
    0x3efa_01a0_19cb_1590,
    0xbe92_7e4f_809c_52ad,
    0x3e21_ee9e_bdb4_b1c4,
    0xbda8_fae9_be88_38d4,
];

/// The high words of |x| where `libm::sincos` takes its kernels alone: 2⁻²⁷√2 ≤ |x| ≲ π/4.
pub(crate) const KERNEL_WORDS: std::ops::RangeInclusive<u32> = 0x3e46_a09e..=0x3fe9_21fb;

/// `libm::sincos(x)` to the bit. Where it takes fdlibm's kernels alone (the angles of a body's
/// turn between events, nearly all) they are inline here, the same operations in the same order;
/// `libm::sincos` elsewhere. Called, it took 52 instructions an angle (2.9 % of an ellipsoid's
/// collision at X0 = 2, φ 0.5, N 256); inline, the collision takes 0.7 % fewer.
#[inline]
pub(crate) fn sin_cos(x: f64) -> (f64, f64) {
    if !KERNEL_WORDS.contains(&(((x.to_bits() >> 32) as u32) & 0x7fff_ffff)) {
        return libm::sincos(x);
    }
    let (s, c) = (
        SIN_KERNEL.map(f64::from_bits),
        COS_KERNEL.map(f64::from_bits),
    );
    let z = x * x;
    let w = z * z;
    // k_sin(x, 0, 0) = x + z x (S1 + z r).
    let r = s[1] + z * (s[2] + z * s[3]) + z * w * (s[4] + z * s[5]);
    let sin = x + z * x * (s[0] + z * r);
    // k_cos(x, 0) = (1 − z/2) + (((1 − (1 − z/2)) − z/2) + z r).
    let r = z * (c[0] + z * (c[1] + z * c[2])) + w * w * (c[3] + z * (c[4] + z * c[5]));
    let half_z = 0.5 * z;
    let one_less = 1.0 - half_z;
    (sin, one_less + (((1.0 - one_less) - half_z) + z * r))
}

/// [`rotate`] of `rot` by t, given |w| = `wn` (not 0) and [`turn_axes`]. Inlined: with its
/// kernels, the compiler called it instead, and wrote each turned matrix to memory and read it
/// back (1.1 % more instructions a collision than with `libm::sincos` called).
#[inline(always)]
fn turn(rot: &M3, wn: f64, axes: &[(V3, V3); 3], t: f64) -> M3 {
    let (s, c) = sin_cos(wn * t);
    let (first, second) = (s / wn, (1.0 - c) / (wn * wn));
    let turned = |k: usize| {
        let (wu, wwu) = &axes[k];
        (rot.row(k).transpose() + wu * first + wwu * second).transpose()
    };
    M3::from_rows(&[turned(0), turned(1), turned(2)])
}

/// A body's free flight from its own time, for the many poses a contact search asks along it:
/// the cross products of Eq. (5) that every pose shares (`turn_axes`) are taken once, at the
/// first pose that turns, and the last pose is kept, which the search asks for again (the
/// distance, the slope and the safe time at one time). Each pose is [`Body::pose_after`]'s, to
/// the bit. Many flights never turn (a box escape whose first step reaches the horizon asks only
/// for the present): taking the cross products at the start cost 1 % more instructions a
/// collision (X0 = 2, φ 0.5, N 256).
pub struct Flight<'a> {
    body: &'a Body,
    w_norm: f64,
    /// [`turn_axes`] of the body, taken at the first turn asked for (never where |w| is 0).
    axes: std::cell::OnceCell<[(V3, V3); 3]>,
    last: std::cell::Cell<Option<(f64, Pose)>>,
}

impl<'a> Flight<'a> {
    pub fn of(body: &'a Body) -> Self {
        let w_norm = body.w.norm();
        Flight {
            body,
            w_norm,
            axes: std::cell::OnceCell::new(),
            last: std::cell::Cell::new(None),
        }
    }

    /// [`Body::pose_after`].
    // Inlined, the new pose goes from registers to `last` and to the caller. Called, it was
    // written to the caller's slot eight bytes at a time and copied to `last` sixteen at a time
    // straight after: loads that span two stores wait for both to reach the cache (about 2 % of
    // an ellipsoid collision's time at X0 = 2, φ = 0.5, N = 256, MEASUREMENTS.md).
    #[inline(always)]
    pub fn pose_after(&self, tau: f64) -> Pose {
        // By the bits: 0.0 and −0.0 give r + v τ apart where v has a zero.
        if let Some((at, pose)) = self.last.get()
            && at.to_bits() == tau.to_bits()
        {
            return pose;
        }
        let b = self.body;
        // `rotate` leaves a body whose |w| is 0 unturned, underflowed or not.
        let rot = if tau != 0.0 && self.w_norm != 0.0 {
            let axes = self.axes.get_or_init(|| turn_axes(&b.rot, &b.w));
            turn(&b.rot, self.w_norm, axes, tau)
        } else {
            b.rot
        };
        let pose = Pose {
            r: b.r + b.v * tau,
            rot,
        };
        self.last.set(Some((tau, pose)));
        pose
    }
}

impl Body {
    /// Pose after a free flight of `tau` (Eq. 6); a body without angular velocity is not rotated.
    // Inlined for the reason `Flight::pose_after` is.
    #[inline(always)]
    pub fn pose_after(&self, tau: f64) -> Pose {
        Pose {
            r: self.r + self.v * tau,
            // Searches start at the present; a rotation by zero would still cost a sine and cosine.
            rot: if tau == 0.0 || self.w == V3::zeros() {
                self.rot
            } else {
                rotate(&self.rot, &self.w, tau)
            },
        }
    }

    /// A copy moved freely to time `t`. Candidates of a prediction are looked at this way: the
    /// stored state stays, and a copy needs no re-orthonormalisation (it accumulates nothing).
    pub fn at(&self, t: f64) -> Body {
        let p = self.pose_after(t - self.t);
        Body {
            r: p.r,
            rot: p.rot,
            t,
            ..*self
        }
    }

    /// Asks for the body's three cache lines ahead of their use.
    #[inline]
    pub fn prefetch(&self) {
        // r, v, t and the start of the rotation; the rest of it; w.
        crate::prefetch(&self.r);
        crate::prefetch(&self.rot[1]);
        crate::prefetch(&self.w);
    }

    /// Moves the stored state to time `t`.
    pub fn advance_to(&mut self, t: f64) {
        let tau = t - self.t;
        if tau != 0.0 {
            self.r += self.v * tau;
            if self.w != V3::zeros() {
                self.rot = orthonormalize(&rotate(&self.rot, &self.w, tau));
            }
            self.t = t;
        }
    }
}

/// Gram–Schmidt on the rows, so that rounding in repeated rotations never accumulates.
pub fn orthonormalize(r: &M3) -> M3 {
    let u0 = r.row(0).transpose().normalize();
    let u1 = r.row(1).transpose();
    let u1 = (u1 - u0 * u0.dot(&u1)).normalize();
    let u2 = u0.cross(&u1);
    M3::from_rows(&[u0.transpose(), u1.transpose(), u2.transpose()])
}

/// ḋ_max of Eq. (32): an upper bound on |ḋ(t)| for two bodies with bounding radii `la`, `lb`.
pub fn ddot_max(a: &Body, b: &Body, la: f64, lb: f64) -> f64 {
    (a.v - b.v).norm() + a.w.norm() * la + b.w.norm() * lb
}

/// How fast the gap between A and B can close along the fixed unit direction `n` (from A to B),
/// forwards and backwards in time: (rot − n·Δv, rot + n·Δv), rot = |w_A × n| L_A + |w_B × n| L_B.
///
/// A refinement of Eq. (32), not in the paper (it is conservative advancement along the normal). The
/// gap of the support functions along a fixed n bounds d from below at every time and equals d where n
/// is the closest-point direction. Translation moves it at n·Δv; rotation changes a support function
/// at most at L·|w × n|, since it is L-Lipschitz in its direction and that direction turns at |w × n|
/// in the body frame (w is constant in free flight, the inertia being isotropic). Hence, for all τ ≥ 0,
/// d(t + τ) ≥ d(t) − τ·forward and d(t − τ) ≥ d(t) − τ·backward; a non-positive rate never closes.
pub fn gap_closing_rates(a: &Body, b: &Body, la: f64, lb: f64, n: &V3) -> (f64, f64) {
    let rot = a.w.cross(n).norm() * la + b.w.cross(n).norm() * lb;
    let opening = n.dot(&(b.v - a.v));
    (rot - opening, rot + opening)
}

/// An upper bound M on d²h/dt² for the support function h of a body rotating at `w`, along a
/// fixed lab direction `n`, with `l` the bounding radius, `rho_max` the largest radius of
/// curvature and `h_min` the least value of h (the half-width of the body's thinnest direction):
/// h(τ) ≤ h(0) + ḣ(0)τ + ½Mτ² for every τ. All its users need only this side (a gap
/// g = … − h_A − h_B closes at most as fast as that lets it).
///
/// In the body frame the direction u turns uniformly about ŵ = w/|w| at the angle θ it makes
/// with ŵ: |u̇| = |w × n| = |w| sin θ, and ü = −|w|² u⊥, u⊥ = u − (u·ŵ)ŵ the part of u that turns
/// (u·ŵ = cos θ stays). Then ḧ = u̇ᵀ∇²h u̇ + x·ü, x = ∇h the support point, with
/// - u̇ᵀ∇²h u̇ ≤ ρ_max |w × n|²;
/// - x·ü = −|w|² (x·u − (u·ŵ)(x·ŵ)) = −|w|² (h(u) − cos θ (x·ŵ)) ≤ |w|² (|cos θ| L − h_min), as
///   h(u) ≥ h_min and |x·ŵ| ≤ L; and x·ü ≤ |x| |ü| ≤ L |w| |w × n| too.
///
/// The second form is the smaller when the body turns about an axis across n (θ near 90°,
/// where the first only was used before): the turning support point then falls back towards
/// the centre, it does not swing out. Measured at X0 = 2, φ = 0.5: see MEASUREMENTS.md, "A
/// tighter bound on how fast a turning body's support can rise".
/// A flat face (ρ_max = +∞, superquadrics with an exponent above 2) gives +∞ while the direction
/// turns, and 0, not NaN, while it does not.
pub fn support_acceleration_bound(w: &V3, n: &V3, l: f64, rho_max: f64, h_min: f64) -> f64 {
    let turn = w.cross(n).norm();
    if turn == 0.0 {
        return 0.0;
    }
    let spin = w.norm();
    let swing = (turn * l).min(w.dot(n).abs() * l - spin * h_min);
    let m = turn * turn * rho_max + spin * swing;
    // Not below 0 (as it is not, but for rounding, where ρ_max ≥ L ≥ h_min): a window 2|ġ|/M
    // must not turn negative. A NaN stays one.
    if m < 0.0 { 0.0 } else { m }
}

/// The bound on h(u(τ)) − h(u₀) − ḣ(0)τ for a body of modulus `m` whose body-frame direction u
/// turns uniformly at `turn` = |u̇| about the axis of its angular velocity (|ü| = |w|·turn), as
/// powers of τ appended to `out`: with |u − u₀| ≤ turn·τ (a chord is no longer than its arc) and
/// x(u₀)·(u − u₀ − u̇₀τ) ≤ L·½|ü|τ² (Taylor, |x(u₀)| ≤ L), the excess is at most
/// ½L|w|·turn·τ² + Σ c_i (turn·τ)^(q_i).
fn push_powers(m: &SupportModulus, turn: f64, w: f64, l: f64, out: &mut Powers) {
    if turn == 0.0 {
        return;
    }
    out.denominator = if m.denominator == 0 {
        0
    } else {
        lcm_at_most(out.denominator, m.denominator, MOST_DENOMINATOR)
    };
    out.push(0.5 * l * w * turn, 2.0);
    for &(c, q) in &m.terms {
        if c > 0.0 {
            out.push(c * pow(turn, q), q);
        }
    }
}

/// P(τ) = Σ a_j τ^(q_j) with a_j > 0 and 1 < q_j ≤ 2, at most seven terms (like powers merged).
#[derive(Clone, Copy, Debug)]
struct Powers {
    len: usize,
    terms: [(f64, f64); 7],
    /// A common [`SupportModulus::denominator`] of the powers (2 is 2M/M for every M), 0 where
    /// there is none.
    denominator: u32,
}

impl Default for Powers {
    fn default() -> Self {
        Powers {
            len: 0,
            terms: [(0.0, 2.0); 7],
            denominator: 1,
        }
    }
}

impl Powers {
    fn push(&mut self, a: f64, q: f64) {
        if let Some(t) = self.terms[..self.len].iter_mut().find(|t| t.1 == q) {
            t.0 += a;
        } else {
            self.terms[self.len] = (a, q);
            self.len += 1;
        }
    }
    fn terms(&self) -> &[(f64, f64)] {
        &self.terms[..self.len]
    }
}

/// The largest τ found with g + ġτ − P(τ) > 0 on (0, τ], for g ≥ 0 (g = 0 needs ġ > 0).
///
/// φ(τ) = g + ġτ − P(τ) is concave (every q_j ≥ 1), so φ > 0 at 0 (or φ(0) = 0 with φ'(0) > 0)
/// and at τ means φ > 0 on (0, τ]: only the returned τ is checked, however it was found. Newton's
/// method from a point past the root descends onto it from above (the tangent of a concave
/// function lies above it, so its zero is never short of the root); the result is that upper
/// bound shrunk until φ is positive there. +∞ when φ never vanishes, 0 when no point is proved.
/// Where the powers are whole multiples of one fraction, in whole powers
/// ([`positive_while_whole`]).
fn positive_while(gap: f64, rate: f64, p: &Powers) -> f64 {
    let terms = p.terms();
    if terms.is_empty() {
        return if rate < 0.0 {
            gap / -rate
        } else {
            f64::INFINITY
        };
    }
    if let Some(tau) = positive_while_whole(gap, rate, p) {
        return tau;
    }
    // A point where φ ≤ 0: each term alone overtakes g + ġτ there (a_j τ^q_j ≥ 2g and ≥ 2ġτ).
    let mut hi = terms
        .iter()
        .map(|&(a, q)| {
            let by_gap = pow(2.0 * gap / a, 1.0 / q);
            let by_rate = pow(2.0 * rate.max(0.0) / a, 1.0 / (q - 1.0));
            by_gap.max(by_rate)
        })
        .fold(f64::INFINITY, f64::min);
    if rate < 0.0 {
        hi = hi.min(gap / -rate);
    }
    if !(hi.is_finite() && hi > 0.0) {
        return 0.0;
    }
    // φ(τ), and τφ'(τ) = ġτ − Σ q_j a_j τ^(q_j).
    descend_to_positive(hi, 1.0, |tau| {
        let (mut value, mut tau_slope) = (gap + rate * tau, rate * tau);
        for &(a, q) in terms {
            let term = a * pow(tau, q);
            value -= term;
            tau_slope -= q * term;
        }
        (tau, value, tau_slope)
    })
}

/// The end of [`positive_while`] and [`positive_while_whole`], in a variable x with τ = x^`order`:
/// from `x` past the root of φ (φ ≤ 0 there), Newton's method down onto it, stopped within
/// 10⁻⁴ of τ, then 10⁻³ of τ off and τ halved until φ is positive there. `at(x)` gives τ, φ(τ)
/// and xφ'(x). The τ returned, or 0 where no point is proved.
fn descend_to_positive(mut x: f64, order: f64, at: impl Fn(f64) -> (f64, f64, f64)) -> f64 {
    for _ in 0..50 {
        let (_, value, x_slope) = at(x);
        if value >= 0.0 || x_slope >= 0.0 {
            break;
        }
        let next = x - x * value / x_slope;
        // τ = x^order changes `order` times as much as x does.
        let done = next >= x * (1.0 - 1e-4 / order);
        x = next.min(x);
        if done {
            break;
        }
    }
    x *= 1.0 - 1e-3 / order;
    // Halving τ is a root of ½ in x: taken only where the first point is not proved.
    let mut halve = None;
    for _ in 0..60 {
        let (tau, value, _) = at(x);
        if value > 0.0 {
            return tau;
        }
        x *= *halve.get_or_insert_with(|| 0.5f64.powf(1.0 / order));
    }
    0.0
}

/// [`positive_while`] where every power is q_j = m_j/M, M the [`Powers::denominator`]: the
/// same Newton's method and the same check, on ψ(s) = φ(s^M), s = τ^(1/M), a polynomial whose
/// powers are products, from a start the bits of [`root_above`] estimate. In powers of τ a safe
/// time of superquadrics at p = 10 called `pow` about five times (its start, 4.3 Newton steps
/// and its check), a tenth of their instructions. `None` where the powers are not whole.
///
/// ψ need not be concave in s (it is where ġ ≤ 0), so a step may land short of the root; there
/// ψ > 0, the search stops, and the shorter τ is what is checked and returned: as safe, a little
/// less long. Where ψ < 0 it decreases (ψ = g + s^M(ġ − Σ a_j s^(m_j − M)), the bracket
/// decreasing and negative there), so every step goes down.
fn positive_while_whole(gap: f64, rate: f64, p: &Powers) -> Option<f64> {
    let big_m = p.denominator;
    if big_m == 0 {
        return None;
    }
    let mut powers = [(0.0, 0u32); 7];
    for (slot, &(a, q)) in powers.iter_mut().zip(p.terms()) {
        let m = q * f64::from(big_m);
        let whole = m.round();
        if (m - whole).abs() > 1e-9 || whole <= f64::from(big_m) || whole > 2.0 * f64::from(big_m) {
            return None;
        }
        *slot = (a, whole as u32 - big_m);
    }
    let powers = &powers[..p.len];
    let order = f64::from(big_m);
    // ψ(s) = g + s^M (ġ − Σ a_j s^(d_j)), and s ψ'(s) = s^M (M ġ − Σ (M + d_j) a_j s^(d_j)).
    let parts = |s: f64| {
        let sm = whole_power(s, big_m);
        let (mut sum, mut weighted) = (0.0, 0.0);
        for &(a, d) in powers {
            let term = a * match d {
                1 => s,
                d if d == big_m => sm,
                d => whole_power(s, d),
            };
            sum += term;
            weighted += f64::from(big_m + d) * term;
        }
        (sm, gap + sm * (rate - sum), sm * (order * rate - weighted))
    };
    // A point where ψ ≤ 0, as `positive_while` finds one: each term alone overtakes g + ġ s^M
    // there (a_j s^(m_j) ≥ 2g and a_j s^(d_j) ≥ 2ġ).
    let mut s = powers
        .iter()
        .map(|&(a, d)| {
            let by_gap = root_above(2.0 * gap / a, big_m + d);
            let by_rate = root_above(2.0 * rate.max(0.0) / a, d);
            by_gap.max(by_rate)
        })
        .fold(f64::INFINITY, f64::min);
    if rate < 0.0 {
        s = s.min(root_above(gap / -rate, big_m));
    }
    if !(s.is_finite() && s > 0.0) {
        return Some(0.0);
    }
    Some(descend_to_positive(s, order, parts))
}

/// One body as seen by [`gap_safe_time`]: its motion, the offset of its support point from its
/// centre (lab frame), its bounding radius L and the modulus of its support function there.
pub struct GapSide<'a> {
    pub body: &'a Body,
    pub offset: V3,
    pub l: f64,
    /// [`Surface::min_support`].
    pub h_min: f64,
    pub modulus: SupportModulus,
}

impl<'a> GapSide<'a> {
    /// Body `body` of shape `s`, turned by `rot` now (rows = body axes), with its support point
    /// `offset` from its centre along the outward unit lab direction `out` (n for A, −n for B).
    pub fn new<S: Surface>(s: &S, body: &'a Body, rot: &M3, offset: V3, out: &V3) -> Self {
        Self::kept(s, body, rot, offset, out, f64::NAN)
    }

    /// [`GapSide::new`] where `offset` is the support point along `out` that
    /// [`Surface::support_point_kept`] found, and `kept` what it left for the modulus.
    pub fn kept<S: Surface>(
        s: &S,
        body: &'a Body,
        rot: &M3,
        offset: V3,
        out: &V3,
        kept: f64,
    ) -> Self {
        GapSide {
            body,
            offset,
            l: s.bounding_radius(),
            h_min: s.min_support(),
            modulus: s.support_modulus_kept(&(rot * out), kept),
        }
    }
}

/// Which way in time a contact-free interval is sought from the present.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Towards {
    Future,
    Past,
}

/// How long the support gap `gap` ≥ 0 between A and B along the fixed unit direction `n` (from A
/// to B) provably stays positive, forwards in time from now: the longer of the linear bound of
/// [`gap_closing_rates`] and g + ġτ − P(τ), with ġ the exact present rate (the support points'
/// velocities along n) and P from each body's [`SupportModulus`]. Neither bound is in the paper.
///
/// Why g + ġτ − P(τ) bounds the gap: g(τ) = n·Δr(τ) − h_A(u_A(τ)) − h_B(u_B(τ)), the centres move
/// linearly and each body-frame direction u turns uniformly about w at |u̇| = |w × n|, so each
/// h(u(τ)) ≤ h(u₀) + ḣ(0)τ + (the powers of [`SupportModulus`]); ġ collects n·Δv and the ḣ(0).
/// Where all moduli are quadratic this is g + ġτ − ½Mτ² with M from
/// [`support_acceleration_bound`], solved in closed form.
pub fn gap_safe_time(a: &GapSide, b: &GapSide, n: &V3, gap: f64) -> f64 {
    gap_safe_time_towards(a, b, n, gap, Towards::Future)
}

/// [`gap_safe_time`] forwards or backwards in time: backwards, the bodies retrace their free
/// flight (−v, −w), so every rate changes sign and every bound on its change stays.
pub fn gap_safe_time_towards(a: &GapSide, b: &GapSide, n: &V3, gap: f64, towards: Towards) -> f64 {
    let (ba, bb) = (a.body, b.body);
    let (forward, backward) = gap_closing_rates(ba, bb, a.l, b.l, n);
    let (closing, sign) = match towards {
        Towards::Future => (forward, 1.0),
        Towards::Past => (backward, -1.0),
    };
    // The linear bound is +∞ where the gap cannot close, and no bound is longer.
    if closing.is_nan() || closing <= 0.0 {
        return f64::INFINITY;
    }
    let rate = sign * n.dot(&((bb.v + bb.w.cross(&b.offset)) - (ba.v + ba.w.cross(&a.offset))));
    match (a.modulus.curvature_radius(), b.modulus.curvature_radius()) {
        (Some(rho_a), Some(rho_b)) => {
            let m = support_acceleration_bound(&ba.w, n, a.l, rho_a, a.h_min)
                + support_acceleration_bound(&bb.w, n, b.l, rho_b, b.h_min);
            longer_of(gap, closing, rate, m)
        }
        _ => {
            let mut p = Powers::default();
            for side in [a, b] {
                let w = side.body.w;
                push_powers(&side.modulus, w.cross(n).norm(), w.norm(), side.l, &mut p);
            }
            (gap / closing).max(positive_while(gap, rate, &p))
        }
    }
}

/// The longer of gap/closing (closing > 0) and [`positive_for`]`(gap, rate, accel)`. Where the
/// gap closes both divide it, 2g/(2·closing) and 2g/(|ġ| + √(ġ² + 2Mg)) (g/|ġ| = 2g/2|ġ| where
/// M = 0): the longer is 2g over the smaller denominator, one division where there were two,
/// to the same bits (doubling is exact).
fn longer_of(gap: f64, closing: f64, rate: f64, accel: f64) -> f64 {
    if rate < 0.0 {
        let twice = if accel > 0.0 {
            (rate * rate + 2.0 * accel * gap).sqrt() - rate
        } else {
            -2.0 * rate
        };
        return 2.0 * gap / (2.0 * closing).min(twice);
    }
    (gap / closing).max(positive_for(gap, rate, accel))
}

/// How long g(τ) ≥ g + ġτ − ½Mτ² stays positive, for g > 0: the positive root of g + ġτ − ½Mτ²,
/// written for a closing gap (ġ < 0) as 2g / (|ġ| + √(ġ² + 2Mg)), which does not cancel where
/// M is small beside ġ²/g.
pub(crate) fn positive_for(gap: f64, rate: f64, accel: f64) -> f64 {
    if accel > 0.0 {
        let root = (rate * rate + 2.0 * accel * gap).sqrt();
        if rate < 0.0 {
            2.0 * gap / (root - rate)
        } else {
            (rate + root) / accel
        }
    } else if rate < 0.0 {
        gap / -rate
    } else {
        f64::INFINITY
    }
}

/// Mass and isotropic moment of inertia; `inv_i` = 0 marks a body whose rotation is not simulated.
#[derive(Clone, Copy, Debug)]
pub struct Inertia {
    pub inv_m: f64,
    pub inv_i: f64,
}

/// Elastic smooth collision of A and B touching at `xc` with unit normal `n` pointing from A to B.
///
/// Eqs. (40) with the impulse magnitude of Eq. (41) written correctly: the numerator is the normal
/// component of the relative velocity of the contact points and the rotational terms of the
/// denominator are squared, Δp = 2 u·n / (1/m_A + 1/m_B + |ρ_A×n|²/I_A + |ρ_B×n|²/I_B).
/// Returns the impulse given to B (A receives its opposite), or `None` if the contact points separate.
pub fn collide(
    a: &mut Body,
    b: &mut Body,
    xc: &V3,
    n: &V3,
    ia: Inertia,
    ib: Inertia,
) -> Option<V3> {
    let ra = xc - a.r;
    let rb = xc - b.r;
    let u = (a.v + a.w.cross(&ra)) - (b.v + b.w.cross(&rb));
    let un = u.dot(n);
    if un <= 0.0 {
        return None;
    }
    let ca = ra.cross(n);
    let cb = rb.cross(n);
    let denom = ia.inv_m + ib.inv_m + ia.inv_i * ca.norm_squared() + ib.inv_i * cb.norm_squared();
    let dp = 2.0 * un / denom;
    a.v -= n * (dp * ia.inv_m);
    b.v += n * (dp * ib.inv_m);
    if ia.inv_i != 0.0 {
        a.w -= ca * (dp * ia.inv_i);
    }
    if ib.inv_i != 0.0 {
        b.w += cb * (dp * ib.inv_i);
    }
    Some(n * dp)
}

#[cfg(test)]
mod tests {
    use super::*;

    proptest::proptest! {
        /// Safe times in whole powers of τ^(1/M) ([`positive_while_whole`]) against the same
        /// search in powers of τ (`powf`, the denominator cleared): φ, evaluated with `powf`, is
        /// positive at the τ returned and at eight points before it; the τ is that search's
        /// within 10⁻⁶ at most (each takes 10⁻³ off the root it found, here of s, there of τ)
        /// and within 0.1 % at least, ġ > 0 included, where ψ need not be concave (no step
        /// landed short in 50,000 cases).
        #[test]
        fn whole_powers_give_the_safe_time_of_powf(
            e in 3u32..=12,
            flat in 1e-6f64..10.0,
            curved in proptest::prop_oneof![proptest::strategy::Just(0.0), 1e-6f64..10.0],
            gap in proptest::prop_oneof![1e-9f64..1e-3, 1e-3f64..1.0],
            rate in proptest::prop_oneof![-10.0f64..10.0, -1e-3f64..1e-3],
        ) {
            let e = f64::from(e);
            let mut whole = Powers::default();
            whole.push(flat, e / (e - 1.0));
            if curved > 0.0 {
                whole.push(curved, 2.0);
            }
            whole.denominator = e as u32 - 1;
            let by_powf = Powers { denominator: 0, ..whole };
            let (tau, reference) = (positive_while(gap, rate, &whole), positive_while(gap, rate, &by_powf));
            let phi = |t: f64| gap + rate * t - flat * t.powf(e / (e - 1.0)) - curved * t * t;
            proptest::prop_assert!(tau > 0.0 && tau.is_finite(), "{tau}");
            for k in 1..=8 {
                let t = tau * f64::from(k) / 8.0;
                proptest::prop_assert!(phi(t) > 0.0, "φ({t:e}) = {:e}, τ {tau:e}", phi(t));
            }
            proptest::prop_assert!(tau <= reference * (1.0 + 1e-6), "{tau:e} against {reference:e}");
            proptest::prop_assert!(tau >= reference * (1.0 - 1e-3), "{tau:e} against {reference:e}");
        }
    }

    proptest::proptest! {
        /// The longer safe time in one division is, to the bit, the longer of the two divided
        /// apart, the linear gap/closing and the quadratic root: closing and opening gaps, with
        /// and without a curvature bound, rates and gaps over many decades.
        #[test]
        fn the_longer_bound_in_one_division_is_the_longer_of_the_two(
            gap in proptest::prop_oneof![1e-12f64..1e-6, 1e-6f64..10.0],
            closing in proptest::prop_oneof![1e-9f64..1e-3, 1e-3f64..100.0],
            rate in proptest::prop_oneof![-100.0f64..100.0, -1e-6f64..1e-6],
            accel in proptest::prop_oneof![proptest::strategy::Just(0.0), 1e-9f64..1e3],
        ) {
            let apart = (gap / closing).max(positive_for(gap, rate, accel));
            let one = longer_of(gap, closing, rate, accel);
            proptest::prop_assert_eq!(one.to_bits(), apart.to_bits(), "{:e} against {:e}", one, apart);
        }
    }

    #[test]
    fn rotation_is_rodrigues_about_w() {
        let w = V3::new(0.0, 0.0, 2.0);
        let r = rotate(&M3::identity(), &w, 0.25 * std::f64::consts::PI);
        // After a quarter turn about z the body x axis (row 0) points along lab y.
        assert!((r.row(0).transpose() - V3::new(0.0, 1.0, 0.0)).norm() < 1e-15);
    }

    proptest::proptest! {
        /// Against nalgebra's axis–angle rotation Q (Rodrigues, right-handed about w): the body
        /// axes turn as u(t) = Q u(0), so the rows of R(t) are those of R(0) Qᵀ.
        #[test]
        fn rotation_matches_the_axis_angle_rotation(
            start in proptest::array::uniform3(-3.0f64..3.0),
            w in proptest::array::uniform3(-20.0f64..20.0),
            t in -2.0f64..2.0,
        ) {
            let rot = *nalgebra::Rotation3::new(V3::from(start)).matrix();
            let w = V3::from(w);
            let expected = rot * nalgebra::Rotation3::new(w * t).matrix().transpose();
            let got = rotate(&rot, &w, t);
            proptest::prop_assert!((got - expected).amax() < 1e-13, "{got} vs {expected}");
            proptest::prop_assert!((got * got.transpose() - M3::identity()).amax() < 1e-13);
        }

        /// A flight's poses are the body's, to the bit, at any times asked in any order, the
        /// same time twice, zero and −0 included, with and without angular velocity, and with
        /// one whose norm underflows.
        #[test]
        fn a_flight_poses_the_body_to_the_bit(
            start in proptest::array::uniform3(-3.0f64..3.0),
            r in proptest::array::uniform3(-3.0f64..3.0),
            v in proptest::array::uniform3(-3.0f64..3.0),
            w in proptest::array::uniform3(-20.0f64..20.0),
            still in proptest::bool::weighted(0.2),
            tiny in proptest::bool::weighted(0.1),
            times in proptest::collection::vec(
                proptest::prop_oneof![-2.0f64..2.0, proptest::strategy::Just(0.0),
                    proptest::strategy::Just(-0.0)],
                1..12,
            ),
        ) {
            let body = Body {
                r: V3::from(r),
                v: V3::from(v),
                t: 0.5,
                rot: *nalgebra::Rotation3::new(V3::from(start)).matrix(),
                w: match (still, tiny) {
                    (true, _) => V3::zeros(),
                    (false, true) => V3::from(w) * 1e-170,
                    (false, false) => V3::from(w),
                },
            };
            let flight = Flight::of(&body);
            let bits = |p: &Pose| (p.r.map(f64::to_bits), p.rot.map(f64::to_bits));
            for &tau in times.iter().chain(times.iter().rev()) {
                proptest::prop_assert_eq!(
                    bits(&flight.pose_after(tau)),
                    bits(&body.pose_after(tau)),
                    "at {:e}", tau
                );
            }
        }
    }

    proptest::prop_compose! {
        /// An ellipsoid (aspect ratios up to 40) turning at `w` about an axis at any angle to the
        /// fixed lab direction n, 0° and 90° included, from any orientation.
        fn turning_ellipsoid()(
            s in proptest::array::uniform3(0.05f64..2.0),
            start in proptest::array::uniform3(-3.0f64..3.0),
            n in proptest::array::uniform3(-1.0f64..1.0),
            w in proptest::array::uniform3(-1.0f64..1.0),
            spin in proptest::prop_oneof![1e-3f64..1.0, 1.0f64..50.0],
            axis in 0..3usize,
        ) -> (crate::ellipsoid::Ellipsoid, Body, V3) {
            let n = (V3::from(n) + V3::new(1e-3, 0.0, 0.0)).normalize();
            let w = (V3::from(w) + V3::new(0.0, 1e-3, 0.0)).normalize();
            // Along n, across it, or anywhere.
            let w = match axis {
                0 => n,
                1 => (w - n * n.dot(&w) + n.cross(&V3::z()) * 1e-3).normalize(),
                _ => w,
            } * spin;
            let body = Body {
                r: V3::zeros(),
                v: V3::zeros(),
                t: 0.0,
                rot: *nalgebra::Rotation3::new(V3::from(start)).matrix(),
                w,
            };
            (crate::ellipsoid::Ellipsoid::new(s[0], s[1], s[2]), body, n)
        }
    }

    proptest::proptest! {
        /// The support along a fixed lab direction of a turning ellipsoid, h(τ) = h(R(τ) n) from
        /// its poses, stays below h(0) + ḣ(0)τ + ½Mτ² over a whole turn either way, and its
        /// second differences below M: M of [`support_acceleration_bound`] bounds ḧ from above.
        #[test]
        fn a_turning_support_rises_no_faster_than_the_bound((e, body, n) in turning_ellipsoid()) {
            let h = |tau: f64| e.support(&(body.pose_after(tau).rot * n));
            let (l, spin) = (e.bounding_radius(), body.w.norm());
            let m = support_acceleration_bound(&body.w, &n, l, e.max_curvature_radius(), e.min_support());
            // Never above the bound L|ü| + ρ|u̇|² alone gives.
            let turn = body.w.cross(&n).norm();
            proptest::prop_assert!(m <= turn * (turn * e.max_curvature_radius() + spin * l) * (1.0 + 1e-12));
            let dt = 1e-5 / spin;
            let rate = (h(dt) - h(-dt)) / (2.0 * dt);
            let period = std::f64::consts::TAU / spin;
            for k in -100..=100 {
                let tau = period * k as f64 / 100.0;
                let slack = 1e-8 * l * (1.0 + (spin * tau).powi(2));
                let rise = h(tau) - h(0.0) - rate * tau;
                proptest::prop_assert!(
                    rise <= 0.5 * m * tau * tau + slack,
                    "h rose {rise:e} above its tangent at {tau:e}, the bound ½Mτ² = {:e}",
                    0.5 * m * tau * tau
                );
                let d = 1e-3 / spin;
                let second = (h(tau + d) - 2.0 * h(tau) + h(tau - d)) / (d * d);
                proptest::prop_assert!(
                    second <= m + 1e-4 * spin * spin * l,
                    "ḧ ≈ {second:e} above M = {m:e} at {tau:e}"
                );
            }
        }
    }

    #[test]
    fn collision_conserves_energy_momentum_angular_momentum() {
        let mut a = Body {
            r: V3::zeros(),
            v: V3::new(1.0, 0.2, -0.1),
            rot: M3::identity(),
            w: V3::new(0.3, -1.0, 0.5),
            t: 0.0,
        };
        let mut b = Body {
            r: V3::new(1.0, 0.3, 0.0),
            v: V3::new(-0.5, 0.1, 0.0),
            rot: M3::identity(),
            w: V3::new(-0.2, 0.1, 0.9),
            t: 0.0,
        };
        let ia = Inertia {
            inv_m: 1.0,
            inv_i: 1.0 / 0.1,
        };
        let ib = Inertia {
            inv_m: 1.0 / 2.0,
            inv_i: 1.0 / 0.3,
        };
        let xc = V3::new(0.6, 0.1, 0.05);
        let n = V3::new(1.0, 0.2, 0.1).normalize();
        let energy = |a: &Body, b: &Body| {
            0.5 * a.v.norm_squared() / ia.inv_m
                + 0.5 * a.w.norm_squared() / ia.inv_i
                + 0.5 * b.v.norm_squared() / ib.inv_m
                + 0.5 * b.w.norm_squared() / ib.inv_i
        };
        let mom = |a: &Body, b: &Body| a.v / ia.inv_m + b.v / ib.inv_m;
        let ang = |a: &Body, b: &Body| {
            a.r.cross(&a.v) / ia.inv_m
                + a.w / ia.inv_i
                + b.r.cross(&b.v) / ib.inv_m
                + b.w / ib.inv_i
        };
        let (e0, p0, l0) = (energy(&a, &b), mom(&a, &b), ang(&a, &b));
        assert!(collide(&mut a, &mut b, &xc, &n, ia, ib).is_some());
        assert!((energy(&a, &b) - e0).abs() < 1e-14 * e0);
        assert!((mom(&a, &b) - p0).norm() < 1e-14);
        assert!((ang(&a, &b) - l0).norm() < 1e-13);
        // Afterwards the contact points separate, so a second call does nothing.
        assert!(collide(&mut a, &mut b, &xc, &n, ia, ib).is_none());
    }
}
