//! Live figures and tables: the `report` crate's drawings of the rows the `results` crate reads,
//! the same path as `sweep report`, so the page and the command cannot drift apart.
//!
//! Cost: one drawing reads every result row of its kind and draws them, O(rows), in a blocking
//! thread (never on the runtime's workers, so the coordinator's RPCs do not wait on it). A drawing
//! is cached with the store's done count; a request redraws only when that count moved **and**
//! the last drawing is older than [`MIN_AGE`] or ten times what it cost, whichever is longer,
//! and one drawing of a figure runs at a time (the others wait for it and share it). So a
//! campaign of 10⁶ jobs whose figure takes 5 s to draw is redrawn at most every 50 s, whatever
//! the number of pages polling: drawing keeps at most a tenth of one core busy per figure.

use std::collections::HashMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

use serde::Serialize;

use coordinator::Store;
use report::{Clock, TableFormat};
use results::Statistic;

/// A drawing is never redrawn sooner than this.
pub const MIN_AGE: Duration = Duration::from_secs(2);
/// A drawing may keep a core busy this fraction of the time.
const DUTY: u32 = 10;

/// A figure or table the page can show: there are done jobs of its kind.
#[derive(Clone, Debug, Serialize)]
pub struct FigureLink {
    pub name: &'static str,
    pub title: &'static str,
    /// `svg` or `table` (JSON rows).
    pub format: &'static str,
    pub url: String,
}

/// What a name draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Drawing {
    /// Table 1 (or 2) as `sweep report table1 --format json` prints it.
    Table { precision: &'static str },
    /// Figure 2 (or 3) as `sweep report fig2 --out F.svg` draws it.
    Fig2 { precision: &'static str },
    /// Figure 7 as `sweep report fig7 --out F.svg` draws it.
    Fig7,
    /// Figure 13 as `sweep report fig13 --out F.svg` draws it.
    Fig13,
}

/// A figure or table the page offers.
#[derive(Clone, Copy, Debug)]
pub struct Figure {
    pub name: &'static str,
    pub title: &'static str,
    drawing: Drawing,
}

impl Figure {
    pub fn link(&self) -> FigureLink {
        let (format, url) = match self.drawing {
            Drawing::Table { .. } => ("table", format!("/api/tables/{}.json", self.name)),
            _ => ("svg", format!("/api/figures/{}.svg", self.name)),
        };
        FigureLink {
            name: self.name,
            title: self.title,
            format,
            url,
        }
    }

    fn is_table(&self) -> bool {
        matches!(self.drawing, Drawing::Table { .. })
    }

    /// The kind of job whose results it draws.
    pub fn kind(&self) -> &'static str {
        match self.drawing {
            Drawing::Table { .. } | Drawing::Fig2 { .. } => "overlap",
            Drawing::Fig7 | Drawing::Fig13 => "edmd",
        }
    }
}

const FIGURES: [Figure; 6] = [
    Figure {
        name: "table1",
        title: "Table 1: mean run time per algorithm and R* (f32)",
        drawing: Drawing::Table { precision: "f32" },
    },
    Figure {
        name: "fig2",
        title: "Figure 2: run time over the (L*, W*) plane (f32)",
        drawing: Drawing::Fig2 { precision: "f32" },
    },
    Figure {
        name: "table2",
        title: "Table 2: as Table 1 in f64",
        drawing: Drawing::Table { precision: "f64" },
    },
    Figure {
        name: "fig3",
        title: "Figure 3: as Figure 2 in f64",
        drawing: Drawing::Fig2 { precision: "f64" },
    },
    Figure {
        name: "fig7",
        title: "Figure 7: EDMD time per collision τ_c against φ",
        drawing: Drawing::Fig7,
    },
    Figure {
        name: "fig13",
        title: "Figure 13: superquadrics, τ_c against the exponent p",
        drawing: Drawing::Fig13,
    },
];

/// What the page shows for a job kind once any of its jobs is done.
pub const BY_KIND: [(&str, &[Figure]); 2] = [
    ("overlap", &[FIGURES[0], FIGURES[1]]),
    ("edmd", &[FIGURES[4], FIGURES[5]]),
];

/// What the page says where it draws nothing, given the done jobs by kind: why there is no
/// figure (yet) rather than an empty space.
pub fn absent(done_by_kind: &[(String, u64)]) -> Vec<String> {
    if done_by_kind.is_empty() {
        return vec!["nothing to draw until a job is done".into()];
    }
    done_by_kind
        .iter()
        .filter(|(kind, _)| !BY_KIND.iter().any(|(k, _)| k == kind))
        .map(|(kind, done)| {
            let kind = if kind == "noop" { "no-op" } else { kind };
            format!("no figure for {kind} jobs ({done} done)")
        })
        .collect()
}

/// Looks a figure up by name; `table` says whether a table (JSON) or a figure (SVG) is asked.
pub fn find(name: &str, table: bool) -> Option<Figure> {
    FIGURES
        .iter()
        .copied()
        .find(|f| f.name == name && f.is_table() == table)
}

/// A drawing, or why there is nothing to draw, and the done count it was made at.
#[derive(Clone, Debug)]
pub struct Drawn {
    pub done: u64,
    pub body: Result<Arc<String>, String>,
    at: Instant,
    cost: Duration,
}

/// The cache of drawings, one slot per figure.
#[derive(Clone)]
pub struct Figures {
    store: Store,
    slots: Arc<HashMap<&'static str, Arc<tokio::sync::Mutex<Option<Drawn>>>>>,
}

impl Figures {
    pub fn new(store: Store) -> Self {
        let slots = FIGURES.iter().map(|f| (f.name, Arc::default())).collect();
        Figures {
            store,
            slots: Arc::new(slots),
        }
    }

    /// `figure` as of `done` jobs done, from the cache when it is fresh enough (see the module).
    pub async fn get(&self, figure: Figure, done: u64) -> Drawn {
        let slot = self.slots[figure.name].clone();
        let mut cached = slot.lock().await;
        if let Some(drawn) = cached.as_ref()
            && (drawn.done == done || drawn.at.elapsed() < MIN_AGE.max(drawn.cost * DUTY))
        {
            return drawn.clone();
        }
        let started = Instant::now();
        let store = self.store.clone();
        let runtime = tokio::runtime::Handle::current();
        let body = tokio::task::spawn_blocking(move || draw(&runtime, &store, figure.drawing))
            .await
            .unwrap_or_else(|panic| Err(format!("drawing {} panicked: {panic}", figure.name)));
        let drawn = Drawn {
            done,
            body: body.map(Arc::new),
            at: Instant::now(),
            cost: started.elapsed(),
        };
        *cached = Some(drawn.clone());
        drawn
    }
}

/// Reads the rows and draws, in a blocking thread: each table and figure estimated as `sweep
/// report` estimates it by default (the tables' statistic, the figures', τ_c by CPU time).
fn draw(
    runtime: &tokio::runtime::Handle,
    store: &Store,
    drawing: Drawing,
) -> Result<String, String> {
    match drawing {
        Drawing::Table { precision } => {
            let rows = runtime
                .block_on(results::overlap_points(store, Statistic::FOR_TABLES))
                .map_err(|e| e.to_string())?;
            let table = report::table1(&rows, precision);
            if table.is_empty() {
                return Err(format!("no {precision} overlap results yet"));
            }
            report::render_table(&table, TableFormat::Json).map_err(|e| e.to_string())
        }
        Drawing::Fig2 { precision } => {
            let rows = runtime
                .block_on(results::overlap_points(store, Statistic::FOR_SURFACES))
                .map_err(|e| e.to_string())?;
            report::fig2_svg(&rows, precision, report::Fig2Options::default())
                .map_err(|e| e.to_string())
        }
        Drawing::Fig7 | Drawing::Fig13 => {
            let rows = runtime
                .block_on(results::edmd_runs(store, Clock::Cpu))
                .map_err(|e| e.to_string())?;
            match drawing {
                Drawing::Fig13 => report::Fig13::new(&rows).and_then(|f| f.svg()),
                _ => report::fig7_svg(&rows),
            }
            .map_err(|e| e.to_string())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_page_says_why_it_draws_nothing() {
        assert_eq!(absent(&[]), ["nothing to draw until a job is done"]);
        let done = |kinds: &[(&str, u64)]| -> Vec<(String, u64)> {
            kinds.iter().map(|(k, n)| (k.to_string(), *n)).collect()
        };
        assert_eq!(
            absent(&done(&[("noop", 19)])),
            ["no figure for no-op jobs (19 done)"]
        );
        assert!(absent(&done(&[("edmd", 2), ("overlap", 5)])).is_empty());
        assert_eq!(
            absent(&done(&[("noop", 3), ("overlap", 5)])),
            ["no figure for no-op jobs (3 done)"]
        );
        let fig2 = find("fig2", false).expect("fig2");
        assert_eq!(fig2.kind(), "overlap");
        assert_eq!(find("fig13", false).expect("fig13").kind(), "edmd");
    }
}
