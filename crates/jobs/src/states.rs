//! State files named by EDMD points (`from_state`): resolved against the plan's folder and
//! hashed when the plan is expanded (the hash is part of the point's id), loaded and checked
//! against that hash when the point runs. The path must be readable where the plan is
//! expanded and where its points run (one machine, or a shared filesystem).

use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use edmd::{SavedState, Scene};

/// The state files a plan names, each read once however many points start from it.
#[derive(Default)]
pub(crate) struct States {
    folder: PathBuf,
    /// Absolute path → (BLAKE3 hex, the state).
    read: RefCell<HashMap<PathBuf, (String, SavedState)>>,
}

impl States {
    /// For a plan whose folder (which anchors relative paths) is `folder`.
    pub(crate) fn in_folder(folder: &Path) -> Self {
        let folder = std::path::absolute(folder).unwrap_or_else(|_| folder.to_path_buf());
        States {
            folder,
            read: RefCell::default(),
        }
    }

    /// The absolute path of `written` and the hash of the file there; the file is decoded
    /// (and kept) to check its format.
    pub(crate) fn resolve(&self, written: &str) -> Result<(String, String), String> {
        let path = self.folder.join(written);
        let mut read = self.read.borrow_mut();
        if !read.contains_key(&path) {
            let (state, hash) = load(&path)?;
            read.insert(path.clone(), (hash, state));
        }
        let hash = read.get(&path).map(|(h, _)| h.clone()).unwrap_or_default();
        Ok((path.display().to_string(), hash))
    }

    /// Whether `scene` (whose `from_state` was resolved) can start from its state file.
    pub(crate) fn check(&self, scene: &Scene) -> Result<(), String> {
        let Some(path) = &scene.from_state else {
            return Ok(());
        };
        match self.read.borrow().get(Path::new(path)) {
            Some((_, state)) => state.check_scene(scene).map_err(|e| format!("{path}: {e}")),
            None => Ok(()),
        }
    }
}

/// Reads and decodes a state file: the state and the BLAKE3 hash (hex) of its bytes.
fn load(path: &Path) -> Result<(SavedState, String), String> {
    let name = path.display();
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read {name}: {e}"))?;
    let hash = blake3::hash(&bytes).to_hex().to_string();
    let state = SavedState::from_bytes(&bytes).map_err(|e| format!("{name}: {e}"))?;
    Ok((state, hash))
}

/// The state an EDMD point starts from, if its scene names one: the file must still have the
/// hash the point's id was made with.
pub(crate) fn start_of(scene: &Scene) -> Result<Option<SavedState>, String> {
    let Some(path) = &scene.from_state else {
        return Ok(None);
    };
    let (state, hash) = load(Path::new(path))?;
    if let Some(expected) = &scene.from_state_blake3
        && *expected != hash
    {
        return Err(format!(
            "{path}: BLAKE3 {hash}, but the point was made with {expected} (the state file changed)"
        ));
    }
    Ok(Some(state))
}
