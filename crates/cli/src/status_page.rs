//! `--http ADDR` of `sweep coordinator` and `sweep run`: the live status page (crate
//! `dashboard`) on the command's own runtime, drawing with the conversions `sweep report` uses.

use std::net::SocketAddr;

use anyhow::Context;
use clap::Args;
use coordinator::Coordinator;
use wire::auth::Token;

#[derive(Args, Clone)]
pub struct HttpArgs {
    /// Also serve the live status page (HTML, JSON, SVG figures) here, e.g. 127.0.0.1:8080; off
    /// loopback it needs the token, which anyone must also present to cancel from the page.
    #[arg(long, value_name = "ADDR")]
    pub http: Option<SocketAddr>,
}

/// How the page turns store rows into report rows: exactly as `sweep report` does.
fn conversions() -> dashboard::figures::RowConversions {
    dashboard::figures::RowConversions {
        overlap_table: |rows| {
            crate::db::report_rows(rows, overlap::estimate::Statistic::FOR_TABLES)
        },
        overlap_figure: |rows| {
            crate::db::report_rows(rows, overlap::estimate::Statistic::FOR_SURFACES)
        },
        edmd: |runs| crate::edmd_report::edmd_rows(runs, report::Clock::Cpu),
    }
}

/// Binds the page (if asked) and serves it in a task of the current runtime; the caller aborts
/// the task when it stops. Returns the task and the page's URL.
pub async fn start(
    args: &HttpArgs,
    coordinator: &Coordinator,
    token: Option<Token>,
    tls: Option<(Vec<u8>, Vec<u8>)>,
) -> anyhow::Result<Option<(tokio::task::JoinHandle<()>, String)>> {
    let Some(listen) = args.http else {
        return Ok(None);
    };
    let bound = dashboard::bind(dashboard::Options { listen, token, tls }).await?;
    let url = bound.url()?;
    let coordinator = coordinator.clone();
    let task = tokio::spawn(async move {
        if let Err(error) = bound
            .serve(coordinator, conversions(), std::future::pending())
            .await
        {
            tracing::error!(%error, "the status page stopped");
        }
    });
    Ok(Some((task, url)))
}

/// Reads `--tls-cert` and `--tls-key`.
pub fn read_tls(
    cert: Option<&std::path::Path>,
    key: Option<&std::path::Path>,
) -> anyhow::Result<Option<(Vec<u8>, Vec<u8>)>> {
    match (cert, key) {
        (Some(cert), Some(key)) => Ok(Some((
            std::fs::read(cert).with_context(|| format!("--tls-cert {}", cert.display()))?,
            std::fs::read(key).with_context(|| format!("--tls-key {}", key.display()))?,
        ))),
        _ => Ok(None),
    }
}
