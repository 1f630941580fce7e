//! The scene: what one EDMD run simulates, parsed from TOML and validated before any work.

use crate::distance::Tolerances;
use crate::superquadric::Superquadric;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Close packing of equal spheres, π/√18.
pub const PHI_MAX_SPHERE: f64 = 0.740_48;
/// Densest known packing of uniaxial ellipsoids (Donev et al., Science 303, 990 (2004)):
/// 0.7707, for aspect ratios beyond √3. Used as a bound for every X0.
pub const PHI_MAX_ELLIPSOID: f64 = 0.7707;
/// The largest superquadric exponent a scene may ask for. Above it the Hessian entries
/// e(e−1)|x/s|^(e−2)/s² of Eq. (77) span so many orders of magnitude between face and edge that the
/// Newton systems lose their digits; the hard-case suite runs up to p = 10 (the paper stopped at 8).
pub const MAX_EXPONENT: f64 = 20.0;

/// Ordered from the most particular to the most general: a sphere is an ellipsoid, an ellipsoid a
/// superquadric (a mixture is simulated as its most general species).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ShapeKind {
    Sphere,
    Ellipsoid,
    /// Eq. (77), with the semi-axes of a uniaxial ellipsoid of the same `x0` and the `exponents`.
    Superquadric,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Neighbours {
    /// Linked cells of bounding-sphere size with cell-crossing events (Sec. 2.6).
    Ll,
    /// Nearest-neighbour lists from oriented bounding parallelepipeds (Sec. 3.3).
    Nnl,
}

/// One simulation. Lengths are in units of the diameter σ of the sphere of equal volume,
/// masses in units of the particle mass, energies in units of k_B T (the initial temperature is 1).
///
/// Ellipsoids are uniaxial: semi-axes a = X0·b along the symmetry axis, b = c across, normalised so
/// that a·b·c = (σ/2)³, i.e. every particle has the volume π/6 of the unit-diameter sphere, whatever X0.
/// Superquadrics have the same proportions a : b : c = X0 : 1 : 1 and the same volume π/6 (see
/// [`Superquadric::with_unit_volume`]). The paper's Sec. 5 instead fixes the smallest semi-axis at
/// 0.8 of its unit of length: a length ℓ here is ℓ · 0.8 / s_min in the paper's units, with s_min
/// the smallest of [`Scene::semi_axes`] (for X0 = 2 and p = 2, s_min = 0.397, so the paper's unit
/// is 0.496 σ); φ, being a volume ratio, is the same number in both.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    pub shape: ShapeKind,
    pub n: usize,
    /// Packing fraction φ = N v / V.
    pub phi: f64,
    /// Aspect ratio X0 = a/b (ellipsoids; must be 1 for spheres).
    #[serde(default = "d_x0")]
    pub x0: f64,
    /// Superquadric exponents [n, m, p] of Eq. (77) on the body axes (a, b, c), each in
    /// [2, [`MAX_EXPONENT`]]; required for `shape = "superquadric"`, refused for other shapes. The
    /// paper's Sec. 5 has n = m = 2 and p on a short axis c = b. Unset, it is not serialised, so
    /// that the ids of the points of other shapes stay what they were before the key existed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exponents: Option<[f64; 3]>,
    /// ε_d of Eq. (39): below this distance the contact search takes small steps and looks for grazing.
    #[serde(default = "d_eps_d")]
    pub eps_d: f64,
    /// Δ_NNL of Eq. (52): the thickness of the bounding parallelepiped; for spheres, how far the
    /// centre may move before its list is rebuilt (the radius of its ball exceeds σ/2 by it).
    /// No serde default: the default depends on the shape and method, see [`default_delta_nnl`].
    pub delta_nnl: f64,
    /// ε_d^nnl of Eq. (61): the escape time from the parallelepiped is taken when the gap falls below it.
    #[serde(default = "d_eps_nnl")]
    pub eps_nnl: f64,
    /// No serde default: the default depends on the shape, see [`default_neighbours`].
    pub neighbours: Neighbours,
    /// Collisions in the measured run.
    #[serde(default = "d_collisions")]
    pub collisions: u64,
    /// Collisions run (and discarded) before measuring.
    #[serde(default = "d_equilibrate")]
    pub equilibrate: u64,
    #[serde(default = "d_seed")]
    pub seed: u64,
    /// Newton–Raphson convergence tolerance (relative residual) for distance and contact time.
    #[serde(default = "d_nr_tol")]
    pub nr_tol: f64,
    #[serde(default = "d_nr_max_iter")]
    pub nr_max_iter: u32,
    /// ε_r of Eqs. (27)–(29): bound on the relative change of α² and β in one Newton step.
    #[serde(default = "d_nr_relax")]
    pub nr_relax: f64,
    /// Steepest-descent iterations (Sec. 2.3.2) allowed when Newton–Raphson fails.
    #[serde(default = "d_sd_max_iter")]
    pub sd_max_iter: u32,
    /// Steepest descent stops when the sine of the angle between normal and separation is below this.
    #[serde(default = "d_sd_tol")]
    pub sd_tol: f64,
    /// Absolute tolerance of Brent's minimisation of d(t) for grazing encounters (Sec. 2.4.2).
    #[serde(default = "d_brent_tol")]
    pub brent_tol: f64,
    /// Overlap audit: a pair overlaps when its contact scale factor is below 1 − audit_tol.
    #[serde(default = "d_audit_tol")]
    pub audit_tol: f64,
    /// A state file (`sweep edmd --save-state`) to start from instead of an initial
    /// configuration, relative to the folder of the scene or plan that names it (whoever reads
    /// the TOML makes it absolute). See [`crate::state`] for what must agree with the saved run.
    /// Unset, neither this nor `from_state_blake3` is serialised, so ids stay what they were.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub from_state: Option<String>,
    /// The BLAKE3 hash (hex) of the `from_state` file: set by whoever resolves the path, part of
    /// a point's id (another state is another point), checked when the file is loaded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub from_state_blake3: Option<String>,
    /// The species of a mixture (`[[species]]` in a scene, `[[edmd.species]]` in a plan; see
    /// [`Species`]). Unset, it is not serialised: a scene without species is the one-species scene
    /// it always was, with the same id. With species, lengths are in units of the first species'
    /// diameter and masses in units of its mass (see [`Species`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub species: Option<Vec<Species>>,
}

/// One species of a mixture, with the shape keys of a one-species scene (`shape`, `x0`,
/// `exponents`).
///
/// - `diameter`: the diameter of the sphere of equal volume (a rigid species is its one-species
///   shape scaled by it), relative to the first species' (the first is the unit of length
///   whatever it writes: every diameter is divided by the first one).
/// - `fraction`: the number fraction x_i; the fractions sum to 1 within [`FRACTION_TOL`]. The
///   counts are N·x_i rounded by largest remainders ([`Scene::species_counts`]).
/// - `polydispersity`: δ, the relative standard deviation of the diameter within the species:
///   each diameter is σ_i (1 + δ g) with g a standard normal truncated to |g| ≤ 3 (redrawn
///   outside), δ in [0, [`MAX_POLYDISPERSITY`]) so that every diameter is positive. The
///   truncation makes the realised spread 0.986 δ.
/// - Masses are proportional to the volume, m = (σ/σ_1)³ m_1 (equal mass density); the moment
///   of inertia of a rigid body is that of a one-species scene's (the inscribed sphere's, see
///   `run`), I = (2/5) m r_min². Spheres of one size and no polydispersity are the one-species
///   scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Species {
    pub shape: ShapeKind,
    /// As a one-species scene's `x0`; unset (1) it is not serialised.
    #[serde(default = "d_x0", skip_serializing_if = "is_one")]
    pub x0: f64,
    /// As a one-species scene's `exponents` (superquadrics only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exponents: Option<[f64; 3]>,
    #[serde(default = "d_diameter")]
    pub diameter: f64,
    pub fraction: f64,
    /// Unset (0) it is not serialised.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub polydispersity: f64,
}

/// How far from 1 the species' fractions may sum.
pub const FRACTION_TOL: f64 = 1e-9;
/// The bound (excluded) on a species' relative size spread.
pub const MAX_POLYDISPERSITY: f64 = 0.3;

fn d_diameter() -> f64 {
    1.0
}
fn is_zero(x: &f64) -> bool {
    *x == 0.0
}
fn is_one(x: &f64) -> bool {
    *x == 1.0
}

fn d_x0() -> f64 {
    1.0
}
fn d_eps_d() -> f64 {
    1e-5
}
fn d_eps_nnl() -> f64 {
    5e-3
}
/// The neighbour method of a scene that names none: the faster one measured for the shape, NNL
/// for every shape. Spheres: τ_c 0.38–0.42 µs against LL's 0.5 at N = 256, φ = 0.45, and the gap
/// grows with N (see the README's τ_c(N) table). Ellipsoids and superquadrics (LL before, as in
/// the paper's default runs): NNL took 1.2–6× less τ_c at the default Δ_NNL (1.4–9× at 0.06) in
/// every case measured, X0 0.5–5 at φ 0.3–0.5 and superquadrics of exponent 4 and 10, without
/// LL's distance fallbacks (up to 2,092 per 2·10⁴ collisions at X0 = 5), and it runs boxes too
/// small for three cells a side (MEASUREMENTS.md, "Rigid bodies on neighbour lists by default").
/// A point's id hashes the resolved method, so a plan written before a default changed names a
/// different point than it did then and is simulated anew, never confused with the old results.
pub fn default_neighbours() -> Neighbours {
    Neighbours::Nnl
}

/// Δ_NNL of a scene that names none: the faster one measured for the shape's lists.
/// Spheres with NNL: 0.25 σ. A ball that wide is rebuilt less often (0.46 → 0.21 rebuilds per
/// collision at φ = 0.45) for a longer list, and the balance favours it at every N measured:
/// τ_c 0.84 against 1.30 µs at N = 256, and at N = 16384 callgrind counts 5631 instructions and
/// 85 misses of a 512 KiB cache per collision against 6942 and 101 at 0.15 (Kolafa's Z the same
/// to 1e-6; see MEASUREMENTS.md). Everything else keeps 0.15: the bounding parallelepipeds of
/// rigid bodies have their own optimum (Figs. 10–11), which moves with φ (at X0 = 2, N 256:
/// 0.25 at φ 0.2, 0.15 at 0.3, 0.08–0.1 at 0.4, 0.085 at 0.5, where searches that cost fewer
/// distances moved it up from 0.06: MEASUREMENTS.md, "Newton from the approach's support
/// points"), and the campaign plans' points written without `delta_nnl` (Fig. 7's X0 = 1
/// ellipsoids) keep their ids; a sphere on linked cells has no lists, so its Δ_NNL, which hashes
/// into the point's id, stays what it was.
///
/// A default that changes what a point is changes its id: a sphere NNL point written without
/// `delta_nnl` before this default names a different point now, and is simulated anew.
pub fn default_delta_nnl(shape: ShapeKind, neighbours: Neighbours) -> f64 {
    match (shape, neighbours) {
        (ShapeKind::Sphere, Neighbours::Nnl) => 0.25,
        _ => 0.15,
    }
}

/// Adds `neighbours` and `delta_nnl` at their defaults for the table's `shape` (and method) where
/// the table names none; a table without a valid shape is left for deserialising to report.
pub fn fill_shape_defaults(table: &mut toml::Table) {
    // A mixture that names no shape has its most general species' shape (the one it is
    // simulated as).
    if !table.contains_key("shape")
        && let Some(shape) = table
            .get("species")
            .and_then(|s| s.as_array())
            .and_then(|s| {
                s.iter()
                    .filter_map(|s| ShapeKind::deserialize(s.get("shape")?.clone()).ok())
                    .max()
            })
            .and_then(|shape| toml::Value::try_from(shape).ok())
    {
        table.insert("shape".into(), shape);
    }
    let Some(shape) = table
        .get("shape")
        .and_then(|v| ShapeKind::deserialize(v.clone()).ok())
    else {
        return;
    };
    if !table.contains_key("neighbours")
        && let Ok(value) = toml::Value::try_from(default_neighbours())
    {
        table.insert("neighbours".into(), value);
    }
    let neighbours = table
        .get("neighbours")
        .and_then(|v| Neighbours::deserialize(v.clone()).ok());
    if !table.contains_key("delta_nnl")
        && let Some(neighbours) = neighbours
    {
        let delta = default_delta_nnl(shape, neighbours);
        table.insert("delta_nnl".into(), toml::Value::Float(delta));
    }
}
fn d_collisions() -> u64 {
    100_000
}
fn d_equilibrate() -> u64 {
    20_000
}
fn d_seed() -> u64 {
    1
}
fn d_nr_tol() -> f64 {
    Tolerances::default().nr_tol
}
fn d_nr_max_iter() -> u32 {
    Tolerances::default().nr_max_iter
}
fn d_nr_relax() -> f64 {
    Tolerances::default().nr_relax
}
fn d_sd_max_iter() -> u32 {
    Tolerances::default().sd_max_iter
}
fn d_sd_tol() -> f64 {
    Tolerances::default().sd_tol
}
fn d_brent_tol() -> f64 {
    1e-12
}
fn d_audit_tol() -> f64 {
    1e-8
}

#[derive(Debug, Error, PartialEq)]
pub enum SceneError {
    /// TOML syntax, unknown key, missing key or wrong type; toml's message names the line.
    #[error("scene: {0}")]
    Parse(String),
    #[error("scene: key `{key}`{}: {reason}", line.map(|l| format!(" (line {l})")).unwrap_or_default())]
    Invalid {
        key: &'static str,
        line: Option<usize>,
        reason: String,
    },
}

impl Scene {
    /// A scene with every optional key at its default.
    pub fn new(shape: ShapeKind, n: usize, phi: f64) -> Self {
        Scene {
            shape,
            n,
            phi,
            x0: d_x0(),
            exponents: (shape == ShapeKind::Superquadric).then_some([2.0; 3]),
            eps_d: d_eps_d(),
            delta_nnl: default_delta_nnl(shape, default_neighbours()),
            eps_nnl: d_eps_nnl(),
            neighbours: default_neighbours(),
            collisions: d_collisions(),
            equilibrate: d_equilibrate(),
            seed: d_seed(),
            nr_tol: d_nr_tol(),
            nr_max_iter: d_nr_max_iter(),
            nr_relax: d_nr_relax(),
            sd_max_iter: d_sd_max_iter(),
            sd_tol: d_sd_tol(),
            brent_tol: d_brent_tol(),
            audit_tol: d_audit_tol(),
            from_state: None,
            from_state_blake3: None,
            species: None,
        }
    }

    /// The number of bodies of each species: ⌊N x_i⌋, and the bodies left over one each to the
    /// species with the largest remainders N x_i − ⌊N x_i⌋ (the first among equal ones), so
    /// that the counts sum to N. One count (N) without species.
    pub fn species_counts(&self) -> Vec<usize> {
        let Some(species) = &self.species else {
            return vec![self.n];
        };
        let exact: Vec<f64> = species.iter().map(|s| s.fraction * self.n as f64).collect();
        let mut counts: Vec<usize> = exact.iter().map(|x| x.floor() as usize).collect();
        let left = self.n.saturating_sub(counts.iter().sum());
        let mut by_remainder: Vec<usize> = (0..exact.len()).collect();
        by_remainder.sort_by(|&a, &b| {
            let rem = |k: usize| exact[k] - exact[k].floor();
            rem(b).total_cmp(&rem(a)).then(a.cmp(&b))
        });
        for &k in by_remainder.iter().cycle().take(left) {
            counts[k] += 1;
        }
        counts
    }

    /// Whether the scene is a mixture the engine simulates with per-body sizes: more than one
    /// species, or one with a size spread. One species of one size is the one-species scene.
    pub fn is_mixture(&self) -> bool {
        self.species
            .as_ref()
            .is_some_and(|s| s.len() > 1 || s.iter().any(|s| s.polydispersity > 0.0))
    }

    /// Parses and validates; range errors name the key and, when found in `src`, its line.
    pub fn from_toml_str(src: &str) -> Result<Scene, SceneError> {
        let parse = |e: toml::de::Error| SceneError::Parse(e.to_string());
        let mut table: toml::Table = src.parse().map_err(parse)?;
        let named: Vec<String> = table.keys().cloned().collect();
        fill_shape_defaults(&mut table);
        // Deserialised from the text, not the table, so that a type error names its line; the
        // defaults go last, where they move no line.
        // Keys appended after a `[[species]]` table would land in it: a mixture is deserialised
        // from the table (its type errors then name the key without the line).
        let scene: Scene = if table.contains_key("species") {
            toml::Value::Table(table).try_into().map_err(parse)?
        } else {
            let mut text = src.to_owned();
            for (key, value) in &table {
                if !named.contains(key) {
                    text.push_str(&format!("\n{key} = {value}\n"));
                }
            }
            toml::from_str(&text).map_err(parse)?
        };
        scene.check().map_err(|e| match e {
            SceneError::Invalid { key, reason, .. } => SceneError::Invalid {
                key,
                line: line_of(src, key),
                reason,
            },
            other => other,
        })?;
        Ok(scene)
    }

    /// Validation, for scenes built in code.
    pub fn validate(&self) -> Result<(), SceneError> {
        self.check()
    }

    /// Semi-axes (a, b, c) with a along the symmetry axis and the volume π/6 (a·b·c = 1/8 for
    /// an ellipsoid).
    pub fn semi_axes(&self) -> [f64; 3] {
        unit_semi_axes(self.shape, self.x0, self.exponents)
    }

    /// The superquadric of a `shape = "superquadric"` scene whose `x0` and `exponents` are valid.
    pub fn superquadric(&self) -> Option<Superquadric> {
        unit_superquadric(self.shape, self.x0, self.exponents)
    }

    /// The smallest semi-axis of any body: of the one shape, or of a mixture's smallest body
    /// (its diameter 3 standard deviations below its species').
    fn smallest_semi_axis(&self) -> f64 {
        let smallest = |s: [f64; 3]| s.into_iter().fold(f64::INFINITY, f64::min);
        match &self.species {
            Some(species) => {
                let unit = species[0].diameter;
                species
                    .iter()
                    .map(|s| {
                        let d = s.diameter / unit * (1.0 - 3.0 * s.polydispersity);
                        smallest(s.semi_axes()) * d
                    })
                    .fold(f64::INFINITY, f64::min)
            }
            None => smallest(self.semi_axes()),
        }
    }

    fn check(&self) -> Result<(), SceneError> {
        let bad = |key: &'static str, reason: String| {
            Err(SceneError::Invalid {
                key,
                line: None,
                reason,
            })
        };
        let floats: [(&'static str, f64); 10] = [
            ("phi", self.phi),
            ("x0", self.x0),
            ("eps_d", self.eps_d),
            ("delta_nnl", self.delta_nnl),
            ("eps_nnl", self.eps_nnl),
            ("nr_tol", self.nr_tol),
            ("nr_relax", self.nr_relax),
            ("sd_tol", self.sd_tol),
            ("brent_tol", self.brent_tol),
            ("audit_tol", self.audit_tol),
        ];
        for (key, v) in floats {
            if !v.is_finite() {
                return bad(key, format!("must be finite, got {v}"));
            }
        }
        // A mixture's shape keys are its species'.
        if self.species.is_none()
            && let Some((key, reason)) = shape_keys_error(self.shape, self.x0, self.exponents)
        {
            return bad(key, reason);
        }
        if self.n < 2 {
            return bad("n", format!("need at least 2 particles, got {}", self.n));
        }
        if self.n > u32::MAX as usize / 2 {
            return bad("n", format!("too many particles: {}", self.n));
        }
        let phi_max = match self.shape {
            ShapeKind::Sphere => PHI_MAX_SPHERE,
            _ => PHI_MAX_ELLIPSOID,
        };
        if self.phi <= 0.0 || self.phi >= phi_max {
            return bad(
                "phi",
                format!(
                    "packing fraction must lie in (0, {phi_max}) (close packing), got {}",
                    self.phi
                ),
            );
        }
        let positive: [(&'static str, f64); 7] = [
            ("eps_d", self.eps_d),
            ("delta_nnl", self.delta_nnl),
            ("eps_nnl", self.eps_nnl),
            ("nr_tol", self.nr_tol),
            ("sd_tol", self.sd_tol),
            ("brent_tol", self.brent_tol),
            ("audit_tol", self.audit_tol),
        ];
        for (key, v) in positive {
            if v <= 0.0 {
                return bad(key, format!("must be > 0, got {v}"));
            }
        }
        if let Some(species) = &self.species {
            self.check_species(species)?;
        }
        let b = self.smallest_semi_axis();
        if self.eps_d >= b {
            return bad(
                "eps_d",
                format!(
                    "must be much smaller than the smallest semi-axis {b}, got {}",
                    self.eps_d
                ),
            );
        }
        if self.eps_nnl >= self.delta_nnl {
            return bad(
                "eps_nnl",
                format!("must be smaller than delta_nnl = {}", self.delta_nnl),
            );
        }
        if self.nr_relax > 1.0 {
            return bad(
                "nr_relax",
                format!("must lie in (0, 1], got {}", self.nr_relax),
            );
        }
        if self.nr_relax <= 0.0 {
            return bad(
                "nr_relax",
                format!("must lie in (0, 1], got {}", self.nr_relax),
            );
        }
        if self.nr_max_iter == 0 {
            return bad("nr_max_iter", "must be at least 1".into());
        }
        if self.collisions == 0 {
            return bad("collisions", "must be at least 1".into());
        }
        Ok(())
    }

    fn check_species(&self, species: &[Species]) -> Result<(), SceneError> {
        let bad = |key: &'static str, reason: String| {
            Err(SceneError::Invalid {
                key,
                line: None,
                reason,
            })
        };
        if species.is_empty() {
            return bad("species", "a mixture needs at least one species".into());
        }
        if self.x0 != 1.0 || self.exponents.is_some() {
            return bad(
                if self.x0 != 1.0 { "x0" } else { "exponents" },
                "a mixture's shapes are its species': give `x0` and `exponents` in each \
                 [[species]]"
                    .into(),
            );
        }
        for (k, s) in species.iter().enumerate() {
            let k = k + 1;
            if let Some((key, reason)) = shape_keys_error(s.shape, s.x0, s.exponents) {
                return bad(key, format!("species {k}: {reason}"));
            }
            if !(s.diameter.is_finite() && s.diameter > 0.0) {
                return bad(
                    "diameter",
                    format!("species {k}: must be finite and > 0, got {}", s.diameter),
                );
            }
            if !(s.fraction.is_finite() && s.fraction > 0.0 && s.fraction <= 1.0) {
                return bad(
                    "fraction",
                    format!("species {k}: must lie in (0, 1], got {}", s.fraction),
                );
            }
            if !(s.polydispersity.is_finite()
                && (0.0..MAX_POLYDISPERSITY).contains(&s.polydispersity))
            {
                return bad(
                    "polydispersity",
                    format!(
                        "species {k}: must lie in [0, {MAX_POLYDISPERSITY}), got {}",
                        s.polydispersity
                    ),
                );
            }
        }
        // The scene is simulated as its most general species (a sphere among ellipsoids is an
        // ellipsoid of X0 = 1), which is the scene's shape.
        let general = species.iter().map(|s| s.shape).max().unwrap_or(self.shape);
        if self.shape != general {
            return bad(
                "shape",
                format!(
                    "a mixture's shape is its most general species' ({general:?}), got {:?}",
                    self.shape
                ),
            );
        }
        let sum: f64 = species.iter().map(|s| s.fraction).sum();
        if (sum - 1.0).abs() > FRACTION_TOL {
            return bad(
                "fraction",
                format!("the species' fractions must sum to 1 (within {FRACTION_TOL}), got {sum}"),
            );
        }
        if let Some(k) = self.species_counts().iter().position(|&c| c == 0) {
            return bad(
                "fraction",
                format!(
                    "species {}: N = {} times its fraction rounds to no body",
                    k + 1,
                    self.n
                ),
            );
        }
        Ok(())
    }
}

/// A sphere of diameter 1 making up the whole scene (`..Default::default()` fills the keys a
/// species leaves unset).
impl Default for Species {
    fn default() -> Self {
        Species {
            shape: ShapeKind::Sphere,
            x0: d_x0(),
            exponents: None,
            diameter: d_diameter(),
            fraction: 1.0,
            polydispersity: 0.0,
        }
    }
}

impl Species {
    /// The species' semi-axes at the equal-volume diameter 1 (before `diameter` scales them).
    pub fn semi_axes(&self) -> [f64; 3] {
        unit_semi_axes(self.shape, self.x0, self.exponents)
    }

    /// The species' superquadric at the equal-volume diameter 1, if it is one.
    pub fn superquadric(&self) -> Option<Superquadric> {
        unit_superquadric(self.shape, self.x0, self.exponents)
    }
}

/// What is wrong with a shape's keys, if anything: the key and why.
fn shape_keys_error(
    shape: ShapeKind,
    x0: f64,
    exponents: Option<[f64; 3]>,
) -> Option<(&'static str, String)> {
    match (shape, exponents) {
        (ShapeKind::Superquadric, None) => {
            return Some((
                "exponents",
                "a superquadric needs `exponents = [n, m, p]` (Eq. 77)".into(),
            ));
        }
        (ShapeKind::Superquadric, Some(e)) => {
            if let Some(x) = e
                .iter()
                .find(|x| !(x.is_finite() && (2.0..=MAX_EXPONENT).contains(*x)))
            {
                return Some((
                    "exponents",
                    format!("each exponent must lie in [2, {MAX_EXPONENT}], got {x}"),
                ));
            }
        }
        (_, Some(_)) => {
            return Some((
                "exponents",
                "only a superquadric has exponents (shape = \"superquadric\")".into(),
            ));
        }
        (_, None) => {}
    }
    if !(x0.is_finite() && x0 > 0.0) {
        return Some((
            "x0",
            format!("aspect ratio must be finite and > 0, got {x0}"),
        ));
    }
    if shape == ShapeKind::Sphere && x0 != 1.0 {
        return Some(("x0", format!("a sphere has x0 = 1, got {x0}")));
    }
    None
}

/// Semi-axes (a, b, c) of a shape of volume π/6 with a along the symmetry axis.
fn unit_semi_axes(shape: ShapeKind, x0: f64, exponents: Option<[f64; 3]>) -> [f64; 3] {
    match unit_superquadric(shape, x0, exponents) {
        Some(q) => [q.s.x, q.s.y, q.s.z],
        None => {
            let b = 0.5 / x0.cbrt();
            [x0 * b, b, b]
        }
    }
}

fn unit_superquadric(
    shape: ShapeKind,
    x0: f64,
    exponents: Option<[f64; 3]>,
) -> Option<Superquadric> {
    match (shape, exponents) {
        (ShapeKind::Superquadric, Some(e)) => Superquadric::with_unit_volume([x0, 1.0, 1.0], e),
        _ => None,
    }
}

/// 1-based line of the first `key = ...` assignment in `src`.
fn line_of(src: &str, key: &str) -> Option<usize> {
    src.lines()
        .position(|l| {
            let l = l.trim_start();
            l.strip_prefix(key)
                .is_some_and(|rest| rest.trim_start().starts_with('='))
        })
        .map(|i| i + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_fill_optional_keys() {
        let s =
            Scene::from_toml_str("shape = \"ellipsoid\"\nn = 256\nphi = 0.3\nx0 = 2.0\n").unwrap();
        assert_eq!(s.neighbours, Neighbours::Nnl);
        let [a, b, c] = s.semi_axes();
        assert!((a / b - 2.0).abs() < 1e-15 && b == c);
        assert!((a * b * c - 0.125).abs() < 1e-15);
    }

    #[test]
    fn spheres_default_to_lists_unless_the_scene_names_cells() {
        let s = Scene::from_toml_str("shape = \"sphere\"\nn = 256\nphi = 0.3\n").unwrap();
        assert_eq!(s.neighbours, Neighbours::Nnl);
        assert_eq!(s, Scene::new(ShapeKind::Sphere, 256, 0.3));
        let named =
            "# neighbours: cells\nshape = \"sphere\"\nn = 256\nphi = 0.3\nneighbours = \"ll\"\n";
        assert_eq!(
            Scene::from_toml_str(named).unwrap().neighbours,
            Neighbours::Ll
        );
        // The appended default moves no line: a bad value still names its own.
        let bad = Scene::from_toml_str("shape = \"sphere\"\nn = \"x\"\nphi = 0.3\n").unwrap_err();
        assert!(bad.to_string().contains("line 2"), "{bad}");
    }

    #[test]
    fn delta_nnl_defaults_by_shape_and_method_and_a_written_one_wins() {
        let parsed =
            |text: &str| Scene::from_toml_str(&format!("n = 256\nphi = 0.3\n{text}\n")).unwrap();
        let cases = [
            ("shape = \"sphere\"", 0.25),
            ("shape = \"sphere\"\nneighbours = \"nnl\"", 0.25),
            ("shape = \"sphere\"\nneighbours = \"ll\"", 0.15),
            ("shape = \"ellipsoid\"\nx0 = 2", 0.15),
            ("shape = \"ellipsoid\"\nx0 = 2\nneighbours = \"nnl\"", 0.15),
            ("shape = \"ellipsoid\"\nx0 = 2\nneighbours = \"ll\"", 0.15),
            ("shape = \"superquadric\"\nexponents = [2, 2, 4]", 0.15),
            ("shape = \"sphere\"\ndelta_nnl = 0.1", 0.1),
            (
                "shape = \"ellipsoid\"\nneighbours = \"nnl\"\ndelta_nnl = 0.06",
                0.06,
            ),
        ];
        for (text, delta) in cases {
            let s = parsed(text);
            assert_eq!(s.delta_nnl, delta, "{text}");
            if !text.contains("delta_nnl") {
                assert_eq!(
                    s.delta_nnl,
                    default_delta_nnl(s.shape, s.neighbours),
                    "{text}"
                );
            }
        }
        assert_eq!(Scene::new(ShapeKind::Sphere, 256, 0.3).delta_nnl, 0.25);
        assert_eq!(Scene::new(ShapeKind::Ellipsoid, 256, 0.3).delta_nnl, 0.15);
        // A Δ_NNL below ε_nnl is still refused, and the error names the line it was written on.
        let e = Scene::from_toml_str("shape = \"sphere\"\nn = 9\nphi = 0.3\neps_nnl = 0.3\n")
            .unwrap_err();
        assert!(
            matches!(
                e,
                SceneError::Invalid {
                    key: "eps_nnl",
                    line: Some(4),
                    ..
                }
            ),
            "{e}"
        );
    }

    #[test]
    fn range_error_names_key_and_line() {
        let e = Scene::from_toml_str("shape = \"sphere\"\nn = 10\nphi = 0.8\n").unwrap_err();
        assert!(
            matches!(
                e,
                SceneError::Invalid {
                    key: "phi",
                    line: Some(3),
                    ..
                }
            ),
            "{e}"
        );
    }
}

#[cfg(test)]
mod species_tests {
    use super::*;

    const BINARY: &str = "n = 1000\nphi = 0.45\n\
        [[species]]\nshape = \"sphere\"\ndiameter = 1.0\nfraction = 0.5\n\
        [[species]]\nshape = \"sphere\"\ndiameter = 1.4\nfraction = 0.5\npolydispersity = 0.08\n";

    #[test]
    fn a_binary_mixture_parses_with_the_shape_of_its_first_species() {
        let s = Scene::from_toml_str(BINARY).unwrap();
        assert_eq!(s.shape, ShapeKind::Sphere);
        assert_eq!(s.neighbours, Neighbours::Nnl);
        let sp = s.species.as_ref().unwrap();
        assert_eq!(sp.len(), 2);
        assert_eq!((sp[1].diameter, sp[1].polydispersity), (1.4, 0.08));
        assert_eq!(sp[0].polydispersity, 0.0);
        assert!(s.is_mixture());
        assert_eq!(s.species_counts(), vec![500, 500]);
    }

    #[test]
    fn counts_round_by_largest_remainders_and_sum_to_n() {
        let mut s = Scene::new(ShapeKind::Sphere, 10, 0.3);
        let sp = |x: f64| Species {
            shape: ShapeKind::Sphere,
            diameter: 1.0,
            fraction: x,
            polydispersity: 0.0,
            ..Default::default()
        };
        // 10 × (1/3, 1/3, 1/3) = 3.33 each: the one left over goes to the first.
        s.species = Some(vec![sp(1.0 / 3.0), sp(1.0 / 3.0), sp(1.0 / 3.0)]);
        assert_eq!(s.species_counts(), vec![4, 3, 3]);
        // 10 × (0.15, 0.25, 0.6) = 1.5, 2.5, 6: one left, to the first of the equal halves.
        s.species = Some(vec![sp(0.15), sp(0.25), sp(0.6)]);
        assert_eq!(s.species_counts(), vec![2, 2, 6]);
        s.validate().unwrap();
        for n in [2, 7, 999, 1001] {
            s.n = n;
            assert_eq!(s.species_counts().iter().sum::<usize>(), n);
        }
        // One species of one size is the one-species scene.
        s.species = Some(vec![sp(1.0)]);
        assert!(!s.is_mixture());
        s.species = None;
        assert_eq!(s.species_counts(), vec![s.n]);
    }

    #[test]
    fn bad_species_name_their_key() {
        let cases = [
            ("fraction = 0.5", "fraction = 0.6", "fraction"),
            ("diameter = 1.4", "diameter = -1.0", "diameter"),
            (
                "polydispersity = 0.08",
                "polydispersity = 0.3",
                "polydispersity",
            ),
            ("diameter = 1.4\n", "diameter = 1.4\nshape2 = 1\n", ""),
        ];
        for (from, to, key) in cases {
            let text = BINARY.replacen(from, to, 1);
            let text = if from == "fraction = 0.5" {
                // The second species' fraction.
                let k = BINARY.rfind(from).unwrap();
                format!("{}{}{}", &BINARY[..k], to, &BINARY[k + from.len()..])
            } else {
                text
            };
            let e = Scene::from_toml_str(&text).unwrap_err();
            match (&e, key) {
                (SceneError::Parse(m), "") => assert!(m.contains("shape2"), "{m}"),
                (SceneError::Invalid { key: k, .. }, _) => assert_eq!(*k, key, "{e}"),
                _ => panic!("{e}"),
            }
        }
        let e = Scene::from_toml_str(
            &BINARY
                .replace("n = 1000", "n = 2\nshape = \"sphere\"")
                .replace("0.5\n", "0.2\n")
                .replacen("fraction = 0.2", "fraction = 0.8", 1),
        )
        .unwrap_err();
        assert!(e.to_string().contains("rounds to no body"), "{e}");
        let e =
            Scene::from_toml_str(&BINARY.replace("n = 1000", "n = 1000\nshape = \"ellipsoid\""))
                .unwrap_err();
        assert!(matches!(e, SceneError::Invalid { key: "shape", .. }), "{e}");
    }

    const RIGID: &str = "n = 1000\nphi = 0.4\n\
        [[species]]\nshape = \"sphere\"\nfraction = 0.5\n\
        [[species]]\nshape = \"ellipsoid\"\nx0 = 2.0\ndiameter = 1.2\nfraction = 0.5\n";

    /// Rigid species take the shape keys of a one-species scene; the scene is its most general
    /// species (its shape, and the defaults of that shape); bad shape keys name their key.
    #[test]
    fn rigid_species_take_the_shape_keys_of_a_scene() {
        let s = Scene::from_toml_str(RIGID).unwrap();
        assert_eq!(s.shape, ShapeKind::Ellipsoid);
        assert_eq!(s.neighbours, default_neighbours());
        assert!(s.is_mixture());
        let sp = s.species.as_ref().unwrap();
        let [a, b, c] = sp[1].semi_axes();
        assert!((a / b - 2.0).abs() < 1e-15 && b == c && (a * b * c - 0.125).abs() < 1e-15);
        let quadric = RIGID.replace(
            "x0 = 2.0",
            "x0 = 2.0\nexponents = [2.0, 2.0, 4.0]\nshape = \"superquadric\"",
        );
        let quadric = quadric.replacen("shape = \"ellipsoid\"\n", "", 1);
        let q = Scene::from_toml_str(&quadric).unwrap();
        assert_eq!(q.shape, ShapeKind::Superquadric);
        assert!(q.species.as_ref().unwrap()[1].superquadric().is_some());
        let key_of = |text: &str| match Scene::from_toml_str(text) {
            Err(SceneError::Invalid { key, .. }) => key,
            other => panic!("{other:?}"),
        };
        // A sphere species with an aspect ratio; a superquadric without exponents; exponents
        // on an ellipsoid; x0 or exponents for the whole mixture; a shape that is not the most
        // general species'; ε_d beyond the smallest body's smallest semi-axis.
        assert_eq!(
            key_of(&RIGID.replacen("fraction = 0.5", "x0 = 2.0\nfraction = 0.5", 1)),
            "x0"
        );
        assert_eq!(
            key_of(&RIGID.replace("\"ellipsoid\"", "\"superquadric\"")),
            "exponents"
        );
        assert_eq!(
            key_of(&RIGID.replace("x0 = 2.0", "x0 = 2.0\nexponents = [2.0, 2.0, 2.0]")),
            "exponents"
        );
        assert_eq!(
            key_of(&RIGID.replace("phi = 0.4", "phi = 0.4\nx0 = 2.0")),
            "x0"
        );
        assert_eq!(
            key_of(&RIGID.replace("phi = 0.4", "phi = 0.4\nshape = \"sphere\"")),
            "shape"
        );
        // X0 = 0.02 at diameter 1.2: a half-thickness of 0.044.
        let flat = RIGID.replace("x0 = 2.0", "x0 = 0.02");
        assert!(Scene::from_toml_str(&format!("eps_d = 0.04\n{flat}")).is_ok());
        assert_eq!(key_of(&format!("eps_d = 0.05\n{flat}")), "eps_d");
    }

    /// A sphere species writes no `x0` and no `exponents`: the ids of sphere mixtures stay what
    /// they were before rigid species existed; a rigid species writes them.
    #[test]
    fn shape_keys_are_serialised_only_where_set() {
        let species_part = |t: String| t[t.find("[[species]]").unwrap_or(0)..].to_owned();
        let t = species_part(toml::to_string(&Scene::from_toml_str(BINARY).unwrap()).unwrap());
        assert!(!t.contains("x0") && !t.contains("exponents"), "{t}");
        let rigid = Scene::from_toml_str(RIGID).unwrap();
        let t = toml::to_string(&rigid).unwrap();
        assert_eq!(species_part(t.clone()).matches("x0").count(), 1, "{t}");
        assert_eq!(Scene::from_toml_str(&t).unwrap(), rigid);
    }

    /// A scene without species serialises without the key, so its point id is what it was.
    #[test]
    fn a_scene_without_species_serialises_as_before() {
        let s = Scene::new(ShapeKind::Sphere, 256, 0.3);
        let t = toml::to_string(&s).unwrap();
        assert!(!t.contains("species"), "{t}");
        let mixed = Scene::from_toml_str(BINARY).unwrap();
        let t = toml::to_string(&mixed).unwrap();
        assert!(t.contains("[[species]]"), "{t}");
        // Polydispersity 0 is not written either.
        assert_eq!(t.matches("polydispersity").count(), 1, "{t}");
        assert_eq!(Scene::from_toml_str(&t).unwrap(), mixed);
    }
}
