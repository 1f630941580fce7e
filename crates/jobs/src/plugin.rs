//! Overlap plugins as files: C shared libraries of `include/sweep_overlap.h` (ABI 1), found
//! relative to the plan, hashed, opened, their entry points looked up.
//!
//! A plan only opens a plugin and looks its symbols up (no function of it is called, though the
//! loader runs its constructors); its name and its verdicts are asked for by the job that runs
//! it, which a worker runs in a child process ([`crate::JobSpec::runs_foreign_code`]), so a
//! plugin that crashes takes only that child with it.

use std::ffi::{CStr, c_char, c_int};
use std::path::{Path, PathBuf};

use libloading::Library;
use overlap::{Algorithm, Foreign, ForeignFn, PluginFile, Precision, Real};

/// The ABI version this build speaks (`SWEEP_OVERLAP_ABI` of the header).
pub const ABI: c_int = 1;
const NAME_SYMBOL: &str = "sweep_overlap_name";
const ABI_SYMBOL: &str = "sweep_overlap_abi";
/// The longest name a plugin may report (it heads a table column).
const MAX_NAME: usize = 40;

#[derive(Debug, thiserror::Error)]
pub enum PluginError {
    #[error("plugin {path}: cannot read it: {source}")]
    Read {
        path: String,
        source: std::io::Error,
    },
    #[error("plugin {path}: cannot load it as a shared library: {reason}")]
    Open { path: String, reason: String },
    #[error("plugin {path}: does not export `{symbol}`, needed for {precision} points")]
    MissingPrecision {
        path: String,
        symbol: &'static str,
        precision: Precision,
    },
    #[error("plugin {path}: does not export `{NAME_SYMBOL}`")]
    MissingName { path: String },
    #[error("plugin {path}: `{ABI_SYMBOL}` returns {found}, this build speaks ABI {ABI}")]
    Abi { path: String, found: c_int },
    #[error("plugin {path}: its name {name:?} {why}")]
    BadName {
        path: String,
        name: String,
        why: String,
    },
    #[error(
        "plugin {path}: its content changed since the plan was read (BLAKE3 {found}, the point has {expected}); submit the plan again to time the new build as a new point"
    )]
    Changed {
        path: String,
        expected: String,
        found: String,
    },
}

/// The symbol of a precision's entry point.
pub fn symbol(precision: Precision) -> &'static str {
    match precision {
        Precision::F32 => "sweep_overlap_f32",
        Precision::F64 => "sweep_overlap_f64",
    }
}

/// BLAKE3 of the file's bytes, lowercase hex.
pub fn hash_file(path: &Path) -> Result<String, PluginError> {
    let bytes = std::fs::read(path).map_err(|source| PluginError::Read {
        path: path.display().to_string(),
        source,
    })?;
    Ok(blake3::hash(&bytes).to_hex().to_string())
}

/// What a plan learns of a plugin: its file as the spec keeps it, and which precisions it
/// exports.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Resolved {
    pub file: PluginFile,
    pub f32: bool,
    pub f64: bool,
}

impl Resolved {
    pub fn exports(&self, precision: Precision) -> bool {
        match precision {
            Precision::F32 => self.f32,
            Precision::F64 => self.f64,
        }
    }
}

/// `written` (as the plan gives it, relative to `folder` unless absolute) hashed, and with
/// `open`, opened and looked up: it must export its name and at least one precision (which ones
/// a point needs is checked per point). Unopened, both precisions are assumed, and a missing
/// one fails the point that needs it when it runs.
pub fn resolve(folder: &Path, written: &str, open: bool) -> Result<Resolved, PluginError> {
    let path: PathBuf = folder.join(written);
    // An absolute path in the spec: a worker started elsewhere finds the same file.
    let path = std::path::absolute(&path).unwrap_or(path);
    let file = PluginFile {
        path: path.display().to_string(),
        blake3: hash_file(&path)?,
    };
    if !open {
        return Ok(Resolved {
            file,
            f32: true,
            f64: true,
        });
    }
    let library = Loaded::open(&path)?;
    library
        .lookup::<unsafe extern "C" fn() -> *const c_char>(NAME_SYMBOL)
        .ok_or_else(|| PluginError::MissingName {
            path: file.path.clone(),
        })?;
    let f32 = library.kernel::<f32>().is_ok();
    let f64 = library.kernel::<f64>().is_ok();
    if !f32 && !f64 {
        return Err(PluginError::MissingPrecision {
            path: file.path,
            symbol: symbol(Precision::F32),
            precision: Precision::F32,
        });
    }
    Ok(Resolved { file, f32, f64 })
}

/// An opened plugin; its kernels are valid while it lives.
pub struct Loaded {
    path: String,
    library: Library,
}

impl Loaded {
    /// Opens `path` and checks its ABI version if it exports one.
    pub fn open(path: &Path) -> Result<Self, PluginError> {
        let shown = path.display().to_string();
        // SAFETY: loading runs the library's initialisers: that is what a plugin is, and why
        // points with plugins run in a child process (`JobSpec::runs_foreign_code`).
        let library = unsafe { Library::new(path) }.map_err(|e| PluginError::Open {
            path: shown.clone(),
            reason: e.to_string(),
        })?;
        let loaded = Self {
            path: shown,
            library,
        };
        if let Some(abi) = loaded.lookup::<unsafe extern "C" fn() -> c_int>(ABI_SYMBOL) {
            // SAFETY: the header declares `int sweep_overlap_abi(void)`.
            let found = unsafe { abi() };
            if found != ABI {
                return Err(PluginError::Abi {
                    path: loaded.path,
                    found,
                });
            }
        }
        Ok(loaded)
    }

    /// Opens the plugin of a spec, after checking that its bytes still have the spec's hash.
    pub fn open_checked(file: &PluginFile) -> Result<Self, PluginError> {
        let path = Path::new(&file.path);
        let found = hash_file(path)?;
        if found != file.blake3 {
            return Err(PluginError::Changed {
                path: file.path.clone(),
                expected: file.blake3.clone(),
                found,
            });
        }
        Self::open(path)
    }

    /// The function `symbol` as type `F` (a function pointer type), if exported.
    fn lookup<F: Copy>(&self, symbol: &str) -> Option<F> {
        // SAFETY: `F` is the type the header declares for `symbol`; the pointer is used only
        // while `self` (the library) lives.
        unsafe { self.library.get::<F>(symbol.as_bytes()) }
            .ok()
            .map(|s| *s)
    }

    fn kernel<T: Real>(&self) -> Result<ForeignFn<T>, PluginError> {
        let precision = precision_of::<T>();
        self.lookup::<ForeignFn<T>>(symbol(precision))
            .ok_or_else(|| PluginError::MissingPrecision {
                path: self.path.clone(),
                symbol: symbol(precision),
                precision,
            })
    }

    /// The name the plugin reports: its algorithm column. It must be an identifier (letters,
    /// digits, `_`) of at most 40 characters that no built-in algorithm has.
    pub fn name(&self) -> Result<String, PluginError> {
        let get = self
            .lookup::<unsafe extern "C" fn() -> *const c_char>(NAME_SYMBOL)
            .ok_or_else(|| PluginError::MissingName {
                path: self.path.clone(),
            })?;
        // SAFETY: the header declares `const char *sweep_overlap_name(void)`, a NUL-terminated
        // string that lives as long as the library; it is copied out at once.
        let pointer = unsafe { get() };
        let bad = |name: String, why: &str| PluginError::BadName {
            path: self.path.clone(),
            name,
            why: why.to_owned(),
        };
        if pointer.is_null() {
            return Err(bad(String::new(), "is a null pointer"));
        }
        // SAFETY: as above; not null.
        let name = unsafe { CStr::from_ptr(pointer) }
            .to_string_lossy()
            .into_owned();
        if name.is_empty() || name.len() > MAX_NAME {
            return Err(bad(name, "must have 1 to 40 characters"));
        }
        if !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err(bad(name, "must hold only letters, digits and `_`"));
        }
        if Algorithm::ALL.iter().any(|a| a.name() == name) {
            return Err(bad(name, "is a built-in algorithm's"));
        }
        Ok(name)
    }

    /// The plugin's kernel in `T`, under its name.
    pub fn foreign<T: Real>(&self) -> Result<Foreign<T>, PluginError> {
        let kernel = self.kernel::<T>()?;
        // SAFETY: the header's signature; the caller keeps `self` (the library) loaded while
        // the kernel is used.
        Ok(unsafe { Foreign::new(self.name()?, kernel) })
    }
}

/// The precision `T` is (`Real` is sealed to `f32` and `f64`).
fn precision_of<T: Real>() -> Precision {
    if T::NAME == f32::NAME {
        Precision::F32
    } else {
        Precision::F64
    }
}
