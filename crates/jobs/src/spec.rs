//! What a job is, what it is called (its id), and roughly how long it takes.

use overlap::{Algorithm, PointSpec, Precision};
use serde::{Deserialize, Serialize};

use crate::canonical::to_canonical_string;
use crate::command::CommandSpec;

/// One schedulable unit of a campaign. Serialised with a `kind` tag (`"overlap"`, `"noop"`) next
/// to the kind's own fields; that JSON is what the store and the wire carry.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum JobSpec {
    /// One benchmark point of the overlap kernels. `seed` here is the plan's seed (a
    /// parameter); the generator is seeded from the id, see [`JobSpec::generator_seed`].
    Overlap(PointSpec),
    /// A job that only sleeps, and fails on purpose, to test the orchestrator.
    Noop(NoopSpec),
    /// One event-driven MD simulation (its scene carries its own seed).
    Edmd(edmd::Scene),
    /// One run of a foreign program (`[[command]]`).
    Command(CommandSpec),
}

/// A no-op job: sleeps `duration_ms`, then fails with probability `fail_rate`, decided by a hash
/// of (job id, attempt) so that a test run is reproducible and a retry may succeed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NoopSpec {
    /// Position in its sweep: what makes the `count` jobs of a sweep distinct points.
    pub index: u64,
    pub duration_ms: u64,
    /// Probability in [0, 1] that an attempt returns an error.
    pub fail_rate: f64,
}

impl JobSpec {
    /// The `kind` tag, as stored next to the job.
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Overlap(_) => "overlap",
            Self::Noop(_) => "noop",
            Self::Edmd(_) => "edmd",
            Self::Command(_) => "command",
        }
    }

    /// Whether running the job runs code that is not part of this build (a program job, an
    /// overlap point's C plugins): such jobs are leased only to workers started with
    /// `--allow-commands`, and plugin points run in a child process, so that a crash of that
    /// code fails the job, not the worker.
    pub fn runs_foreign_code(&self) -> bool {
        match self {
            Self::Overlap(p) => !p.plugins.is_empty(),
            Self::Command(_) => true,
            Self::Noop(_) | Self::Edmd(_) => false,
        }
    }

    /// Whether running the job loads foreign code into the process that runs it (an overlap
    /// point's C plugins), which a worker therefore runs in a child process; a program job is
    /// a process of its own already.
    pub fn loads_foreign_code(&self) -> bool {
        matches!(self, Self::Overlap(p) if !p.plugins.is_empty())
    }

    /// The scheduling pass the store leases the job in (every queued job of an earlier pass of
    /// one submission before any of a later one): an overlap point's visit, 0 for its first
    /// and for every other kind of job.
    pub fn pass(&self) -> u32 {
        match self {
            Self::Overlap(p) => p.visit.unwrap_or(0),
            Self::Noop(_) | Self::Edmd(_) | Self::Command(_) => 0,
        }
    }

    /// The spec as canonical JSON (sorted keys, numbers by value: `4` and `4.0` are the same
    /// bytes), the input of [`JobSpec::id`].
    pub fn canonical_json(&self) -> String {
        // Serialising a JobSpec cannot fail: it has no maps with non-string keys; a non-finite
        // float (rejected by validation anyway) would become `null`.
        let value = serde_json::to_value(self).unwrap_or(serde_json::Value::Null);
        to_canonical_string(&value)
    }

    fn digest(&self) -> blake3::Hash {
        blake3::hash(self.canonical_json().as_bytes())
    }

    /// The point's identity: lowercase hex of the BLAKE3 hash of [`JobSpec::canonical_json`]
    /// (64 characters). Equal parameters give equal ids, so resubmitting a plan finds its points
    /// done, and extending a list adds only the new points.
    pub fn id(&self) -> String {
        self.digest().to_hex().to_string()
    }

    /// The seed of the configuration generator: the first 8 bytes (little-endian) of the
    /// BLAKE3 hash the id is the hex of. Every point has its own stream, reproducible from its id
    /// alone; change the plan's `seed` to draw an independent campaign.
    pub fn generator_seed(&self) -> u64 {
        let bytes = self.digest();
        let mut first = [0u8; 8];
        first.copy_from_slice(&bytes.as_bytes()[..8]);
        u64::from_le_bytes(first)
    }

    /// Rough wall time of one attempt, for a plan's total and a campaign's ETA. Overlap: a
    /// per-configuration cost of each algorithm (measured on a Zen 4 core, 200 000
    /// configurations, 40 % acceptance, a loaded 2-core machine) plus the plain read and the
    /// generation of each set.
    pub fn estimate_seconds(&self) -> f64 {
        match self {
            Self::Overlap(p) => {
                let per_config_ns: f64 = generation_ns(p.precision)
                    + stream_ns(p.precision)
                    + p.algorithms
                        .iter()
                        .map(|&a| check_ns(a, p.precision))
                        .sum::<f64>()
                    + p.plugins.len() as f64 * plugin_check_ns(p.precision);
                per_config_ns * p.configurations as f64 * f64::from(p.repeats) * 1e-9
            }
            Self::Noop(n) => n.duration_ms as f64 * 1e-3,
            // Rough costs measured on this project's reference machine: per collision on the
            // analytic sphere path and on the Newton–Raphson ellipsoid path (N = 256, φ 0.25–0.57,
            // X0 0.25–4: 10–240 µs, 60 on average), and the initial state of an ellipsoid run
            // (0.9 s on average at N = 256; deploy/plans/edmd-figures-quick.toml); superquadrics
            // at p = 2 (X0 = 2, φ = 0.256, N = 512, LL: 0.28 ms of CPU per collision, 5.5 s of
            // initial state), higher p costing more.
            Self::Edmd(scene) => {
                let (per_collision, init_per_particle) = match scene.shape {
                    edmd::ShapeKind::Sphere => (2e-6, 1e-5),
                    edmd::ShapeKind::Ellipsoid => (6e-5, 3.5e-3),
                    edmd::ShapeKind::Superquadric => (3e-4, 1.1e-2),
                };
                (scene.collisions + scene.equilibrate) as f64 * per_collision
                    + scene.n as f64 * init_per_particle
            }
            // Nothing is known of a foreign program: a minute, or its timeout if shorter (the
            // coordinator learns what the kind really takes, `coordinator::durations`).
            Self::Command(c) => c.timeout_s.map_or(60.0, |t| t.min(60.0)),
        }
    }
}

/// Generating one configuration, parallel over the pool (two cores).
fn generation_ns(precision: Precision) -> f64 {
    match precision {
        Precision::F32 => 90.0,
        Precision::F64 => 110.0,
    }
}

/// The plain read of one configuration (24 B in f32, 48 B in f64).
fn stream_ns(precision: Precision) -> f64 {
    match precision {
        Precision::F32 => 2.0,
        Precision::F64 => 4.0,
    }
}

/// One check of a plugin, unknown code: as the slowest built-in per-pair kernel (QRI), so
/// that an estimate errs long. Its verdict check (untimed, about 0.1 s) is in the noise.
fn plugin_check_ns(precision: Precision) -> f64 {
    check_ns(Algorithm::Qri, precision)
}

/// One check of `algorithm`, averaged over the (L*, W*, R*) plane.
fn check_ns(algorithm: Algorithm, precision: Precision) -> f64 {
    let (f32_ns, f64_ns) = match algorithm {
        Algorithm::Arvo => (28.0, 40.0),
        Algorithm::Qri => (32.0, 45.0),
        Algorithm::Qrf => (28.0, 36.0),
        Algorithm::Sse => (12.0, 34.0),
        Algorithm::Ocsi => (14.0, 21.0),
        Algorithm::OcsiBatch => (2.0, 4.5),
    };
    match precision {
        Precision::F32 => f32_ns,
        Precision::F64 => f64_ns,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(l_star: f64) -> JobSpec {
        JobSpec::Overlap(PointSpec {
            l_star,
            w_star: 2.0,
            r_star: 0.5,
            acceptance: 0.4,
            configurations: 1000,
            repeats: 3,
            precision: Precision::F32,
            algorithms: Algorithm::ALL.to_vec(),
            seed: 0,
            ci_target: None,
            time_cap_s: None,
            verdict_check: None,
            visit: None,
            plugins: Vec::new(),
        })
    }

    #[test]
    fn json_is_tagged_and_round_trips() {
        let job = point(4.0);
        let text = serde_json::to_string(&job).expect("serialises");
        assert!(text.contains(r#""kind":"overlap""#), "{text}");
        let back: JobSpec = serde_json::from_str(&text).expect("deserialises");
        assert_eq!(back, job);
        assert_eq!(back.id(), job.id());
        // The canonical form is itself a spec: a store may keep it and hand it back.
        let canonical: JobSpec =
            serde_json::from_str(&job.canonical_json()).expect("canonical JSON deserialises");
        assert_eq!(canonical, job);
        let noop: JobSpec =
            serde_json::from_str(r#"{"kind":"noop","index":3,"duration_ms":0,"fail_rate":0}"#)
                .expect("a noop job parses");
        assert_eq!(noop.kind(), "noop");
    }

    #[test]
    fn id_depends_on_values_only() {
        let a = point(4.0);
        let b: JobSpec =
            serde_json::from_str(&a.canonical_json().replace("\"l_star\":4", "\"l_star\":4.0"))
                .expect("parses");
        assert_eq!(a.id(), b.id());
        assert_eq!(a.id().len(), 64);
        assert_ne!(a.id(), point(5.0).id());
        assert_ne!(a.generator_seed(), point(5.0).generator_seed());
        assert_eq!(a.generator_seed(), point(4.0).generator_seed());
    }

    /// The precision keys came after points had ids: unset, they are not part of the canonical
    /// form, so every existing point keeps its id; set, they make a new point.
    #[test]
    fn precision_keys_leave_existing_ids_alone() {
        let plain = point(4.0);
        assert_eq!(
            plain.canonical_json(),
            r#"{"acceptance":0.4,"algorithms":["arvo","qri","qrf","sse","ocsi","ocsi_batch"],"configurations":1000,"kind":"overlap","l_star":4,"precision":"f32","r_star":0.5,"repeats":3,"seed":0,"w_star":2}"#
        );
        let JobSpec::Overlap(p) = plain.clone() else {
            unreachable!()
        };
        let precise = JobSpec::Overlap(PointSpec {
            ci_target: Some(0.01),
            ..p.clone()
        });
        assert!(precise.canonical_json().contains(r#""ci_target":0.01"#));
        assert_ne!(precise.id(), plain.id());
        let capped = JobSpec::Overlap(PointSpec {
            ci_target: Some(0.01),
            time_cap_s: Some(30.0),
            ..p.clone()
        });
        assert_ne!(capped.id(), precise.id());
        let checked = JobSpec::Overlap(PointSpec {
            verdict_check: Some(1000),
            ..p
        });
        assert!(checked.canonical_json().contains(r#""verdict_check":1000"#));
        assert_ne!(checked.id(), plain.id());
        // A stored spec without the keys still reads.
        let stored: JobSpec =
            serde_json::from_str(&plain.canonical_json()).expect("old specs parse");
        assert_eq!(stored, plain);
    }

    #[test]
    fn estimates_scale_with_work() {
        let one = point(4.0).estimate_seconds();
        assert!(one > 0.0);
        let JobSpec::Overlap(mut p) = point(4.0) else {
            unreachable!()
        };
        p.configurations *= 10;
        assert!((JobSpec::Overlap(p).estimate_seconds() / one - 10.0).abs() < 1e-9);
        let noop = JobSpec::Noop(NoopSpec {
            index: 0,
            duration_ms: 1500,
            fail_rate: 0.0,
        });
        assert_eq!(noop.estimate_seconds(), 1.5);
    }
}
