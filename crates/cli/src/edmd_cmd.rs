//! `sweep edmd SCENE.toml`: one event-driven simulation, no database, on one pinned core.

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;
use edmd::{FrameEvery, Scene};
use indicatif::{ProgressBar, ProgressStyle};

use crate::output::{Format, print_json, print_table};
use crate::state_file;
use crate::system;
use crate::trajectory::Trajectory;

#[derive(Args)]
pub struct EdmdArgs {
    scene: PathBuf,
    /// Write the final configuration here (JSON: box and particles).
    #[arg(long)]
    dump: Option<PathBuf>,
    /// The core to pin the simulation to (default: the first core available).
    #[arg(long)]
    core: Option<usize>,
    /// Save the run's state here at the end (a state file: a scene's `from_state` continues
    /// it bit for bit, or starts from its configuration).
    #[arg(long, value_name = "FILE")]
    save_state: Option<PathBuf>,
    /// Also save the state every K collisions (counted from the end of the initial state),
    /// replacing the file each time.
    #[arg(long, value_name = "K", requires = "save_state", value_parser = clap::value_parser!(u64).range(1..))]
    checkpoint_every: Option<u64>,
    /// Write a trajectory here, in GSD with HOOMD's schema (OVITO and the `gsd` Python package
    /// read it): a frame at the start and then as `--every` says.
    #[arg(long, value_name = "FILE.gsd")]
    trajectory: Option<PathBuf>,
    /// Between trajectory frames: K collisions (`20000`), or a simulated time with its unit
    /// `t`, σ √(m / k_B T) (`0.5t`: a frame at the first collision at or after each multiple).
    /// Default: 10 collisions per particle, 10⁴·N/1000.
    #[arg(long, value_name = "K|Tt", requires = "trajectory", value_parser = parse_every)]
    every: Option<FrameEvery>,
}

/// `--every`: a positive whole number of collisions, or a positive time ending in `t`.
fn parse_every(text: &str) -> Result<FrameEvery, String> {
    let bad = || {
        format!(
            "expected collisions (e.g. 20000) or a time in σ√(m/k_BT) ending in t (e.g. 0.5t), got {text:?}"
        )
    };
    match text.strip_suffix('t') {
        Some(time) => match time.parse::<f64>() {
            Ok(dt) if dt.is_finite() && dt > 0.0 => Ok(FrameEvery::Time(dt)),
            _ => Err(bad()),
        },
        None => match text.parse::<u64>() {
            Ok(k) if k > 0 => Ok(FrameEvery::Collisions(k)),
            _ => Err(bad()),
        },
    }
}

pub fn run(args: &EdmdArgs, format: Format) -> anyhow::Result<()> {
    let name = args.scene.display().to_string();
    let text =
        std::fs::read_to_string(&args.scene).with_context(|| format!("cannot read {name}"))?;
    let scene = Scene::from_toml_str(&text).with_context(|| name.clone())?;
    let folder = args.scene.parent().unwrap_or(Path::new("."));
    let from = state_file::start_of(&scene, folder).with_context(|| name.clone())?;
    let mut trajectory = match &args.trajectory {
        Some(path) => Some((Trajectory::create(path, &scene)?, path)),
        None => None,
    };
    // τ_c is a CPU time per collision: the run must not migrate between cores.
    let core = match args.core {
        Some(core) => core,
        None => *system::available_cores()?
            .first()
            .context("no core available")?,
    };
    system::pin_current_thread(core)?;
    let total = scene.equilibrate + scene.collisions;
    let bar = if format == Format::Json {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(total)
    };
    bar.set_style(ProgressStyle::with_template(
        "{msg} [{bar:30}] {pos}/{len} collisions, ETA {eta}",
    )?);
    bar.set_message(format!("{:?} N={} φ={}", scene.shape, scene.n, scene.phi));
    let mut on_state = |state: &edmd::SavedState| match &args.save_state {
        Some(path) => state_file::save(path, state).map_err(|e| format!("{e:#}")),
        None => Ok(()),
    };
    let mut on_frame = |frame: &edmd::Frame| match trajectory.as_mut() {
        Some((t, path)) => t
            .write(frame)
            .map_err(|e| format!("cannot write {}: {e}", path.display())),
        None => Ok(()),
    };
    let hooks = edmd::Hooks {
        from,
        checkpoint_every: args.checkpoint_every.unwrap_or(0),
        save_final: args.save_state.is_some(),
        on_state: Some(&mut on_state),
        frame_every: match args.trajectory {
            Some(_) => args
                .every
                .unwrap_or(FrameEvery::Collisions(10 * scene.n as u64)),
            None => FrameEvery::Never,
        },
        on_frame: Some(&mut on_frame),
    };
    let (report, state) = edmd::run_with_hooks(&scene, &mut |done| bar.set_position(done), hooks)
        .with_context(|| name.clone())?;
    bar.finish_and_clear();
    if let Some((t, path)) = &trajectory {
        tracing::info!("{} frames in {}", t.frames(), path.display());
    }
    if let Some(dump) = &args.dump {
        let json = serde_json::to_string_pretty(&state)?;
        std::fs::write(dump, json).with_context(|| format!("cannot write {}", dump.display()))?;
    }
    match format {
        Format::Json => print_json(&report),
        _ => {
            let value = serde_json::to_value(&report)?;
            let rows: Vec<Vec<String>> = value
                .as_object()
                .map(|o| {
                    o.iter()
                        .map(|(k, v)| vec![k.clone(), v.to_string()])
                        .collect()
                })
                .unwrap_or_default();
            print_table(&["quantity", "value"], &rows);
            Ok(())
        }
    }
}
