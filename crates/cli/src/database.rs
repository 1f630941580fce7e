//! The one way a command opens a result database and the one runtime it reads it on.

use std::path::Path;

use anyhow::{Context, bail};
use coordinator::Store;

/// The runtime of a command that only reads a database: one per command.
fn runtime() -> anyhow::Result<tokio::runtime::Runtime> {
    Ok(tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()?)
}

/// Opens `db` read-only (reading never creates, migrates or changes the file), runs `read` on
/// it, and closes it.
pub fn read<T>(
    db: &Path,
    read: impl AsyncFnOnce(&Store) -> anyhow::Result<T>,
) -> anyhow::Result<T> {
    runtime()?.block_on(async {
        let store = open_read_only(db).await?;
        let result = read(&store).await;
        store.close().await;
        result
    })
}

async fn open_read_only(db: &Path) -> anyhow::Result<Store> {
    if !db.exists() {
        bail!("{}: no such database", db.display());
    }
    match Store::open_read_only(db).await {
        Err(error @ store::Error::SchemaOutdated { .. }) => bail!(
            "cannot open {}: {error}; `sweep run PLAN --db {}` or `sweep coordinator --db {}` migrates it",
            db.display(),
            db.display(),
            db.display()
        ),
        // It names the file already.
        Err(error @ store::Error::Open { .. }) => Err(error.into()),
        opened => opened.with_context(|| format!("cannot open {}", db.display())),
    }
}

/// Opens (creating and migrating) `db` for a command that writes it: local mode, a coordinator.
pub async fn open(db: &Path) -> anyhow::Result<Store> {
    match Store::open(db).await {
        Err(error @ (store::Error::Open { .. } | store::Error::Migrate { .. })) => {
            Err(error.into())
        }
        opened => opened.with_context(|| format!("cannot open {}", db.display())),
    }
}
