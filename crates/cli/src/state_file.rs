//! State files on disk (`--save-state`, `--checkpoint-every`, the scene key `from_state`): the
//! bytes are the `edmd` crate's ([`edmd::state`]); here they are read, hashed and written.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use edmd::{SavedState, Scene};

/// Reads a state file: the state and the BLAKE3 hash (hex) of its bytes.
pub fn load(path: &Path) -> anyhow::Result<(SavedState, String)> {
    let name = path.display();
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {name}"))?;
    let hash = blake3::hash(&bytes).to_hex().to_string();
    let state = SavedState::from_bytes(&bytes).with_context(|| format!("{name}"))?;
    Ok((state, hash))
}

/// Writes `state` to `path` whole or not at all (a temporary file beside it, renamed), so that
/// a run killed while it checkpoints leaves the previous checkpoint.
pub fn save(path: &Path, state: &SavedState) -> anyhow::Result<()> {
    let bytes = state.to_bytes()?;
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    let tmp = PathBuf::from(tmp);
    std::fs::write(&tmp, bytes).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("cannot write {}", path.display()))
}

/// The state a scene starts from, if it names one: `from_state` is taken relative to `folder`
/// (the scene's or plan's), its hash checked against `from_state_blake3` where the scene has
/// one, and its system against the scene's. Errors name the file and the key.
pub fn start_of(scene: &Scene, folder: &Path) -> anyhow::Result<Option<SavedState>> {
    let Some(from) = &scene.from_state else {
        return Ok(None);
    };
    let path = folder.join(from);
    let (state, hash) = load(&path).context("scene key `from_state`")?;
    if let Some(expected) = &scene.from_state_blake3
        && *expected != hash
    {
        bail!(
            "{}: BLAKE3 {hash}, but the scene's `from_state_blake3` is {expected} (the state file changed)",
            path.display()
        );
    }
    state
        .check_scene(scene)
        .with_context(|| format!("{}: scene key `from_state`", path.display()))?;
    Ok(Some(state))
}
