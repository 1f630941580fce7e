//! `sweep edmd SCENE.toml`: one event-driven simulation, no database, on one pinned core.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use edmd::Scene;
use indicatif::{ProgressBar, ProgressStyle};

use crate::output::{Format, print_json, print_table};
use crate::system;

#[derive(Args)]
pub struct EdmdArgs {
    scene: PathBuf,
    /// Write the final configuration here (JSON: box and particles).
    #[arg(long)]
    dump: Option<PathBuf>,
    /// The core to pin the simulation to (default: the first core available).
    #[arg(long)]
    core: Option<usize>,
}

pub fn run(args: &EdmdArgs, format: Format) -> anyhow::Result<()> {
    let name = args.scene.display().to_string();
    let text =
        std::fs::read_to_string(&args.scene).with_context(|| format!("cannot read {name}"))?;
    let scene = Scene::from_toml_str(&text).with_context(|| name.clone())?;
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
    let (report, state) = edmd::run_with_state(&scene, &mut |done| bar.set_position(done))
        .with_context(|| name.clone())?;
    bar.finish_and_clear();
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
