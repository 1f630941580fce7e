//! `--http ADDR` of `sweep coordinator` and `sweep run`: the live status page (crate
//! `dashboard`) on the command's own runtime.

use coordinator::Coordinator;
use wire::auth::Token;

use crate::args::HttpArgs;

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
        if let Err(error) = bound.serve(coordinator, std::future::pending()).await {
            tracing::error!(%error, "the status page stopped");
        }
    });
    Ok(Some((task, url)))
}
