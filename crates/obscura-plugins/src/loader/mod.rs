//! Projection plugins from shared libraries: search, load, check, and adapt to the SDK's traits.
//!
//! A plugin is a shared library (`<Name>.so`, `.dylib` on macOS, `.dll` on Windows) exporting
//! `obscura_projection_entry` (see `include/obscura/projection.h` and [`obscura_sdk::abi`]). Loading one
//!
//! 1. checks the file before the system loader sees it ([`validate`]: file type, architecture, size,
//!    the entry symbol a function), so a truncated or foreign file is an error, not a crash;
//! 2. opens the library (never unloaded: the [`libloading::Library`] is leaked, and a library opened
//!    twice in a process is opened once);
//! 3. looks up the entry point and calls it with the host's ABI version;
//! 4. checks the descriptor before calling anything else: not null, the same ABI version, a
//!    `struct_size` at least this version's layout, a name, the required function pointers, and a
//!    well-formed parameter table (copied into the host);
//! 5. registers a [`PluginFactory`] — an ordinary [`ProjectionFactory`] — in the [`Registry`], so a
//!    loaded projection goes through the same camera stage, validation and culling as a built-in.
//!
//! Nothing of the plugin runs but its entry point: the registry calls `init`, with the library's path,
//! just before the first projection is created, so listing plugins (`obscura plugins`, [`load_all`])
//! never runs one, and a plugin whose `init` fails is reported by the `create` that needed it, naming
//! the file.
//!
//! [`ensure`] is what the CLI calls with a name from the user or a scene: a registered name is used as
//! is, a path is loaded, and an unknown name is looked up as `<Name>.so` along [`PluginSearch`]
//! (`--plugin-path` directories, then `OBSCURA_PLUGIN_PATH`).
//!
//! | file | what |
//! |---|---|
//! | `search.rs` | [`PluginSearch`], [`library_file_name`], [`PLUGIN_PATH_VAR`] |
//! | [`crate::library`] | one library in process: [`validate`], opening, [`PluginFactory`], [`PluginLoadError`] |
//! | here | [`load_file`], [`load_all`], [`ensure`]: in process, or in a worker ([`crate::isolate`]) |

use std::path::{Path, PathBuf};

use obscura_host::Registry;
use obscura_sdk::{ProjectionFactory, did_you_mean};

mod search;

pub use crate::library::{DESCRIPTOR_V1_SIZE, ENTRY_SYMBOL_NUL, PluginFactory, PluginLoadError, validate};
pub use search::{PLUGIN_PATH_VAR, PluginSearch, library_file_name, looks_like_path};

/// Loads the plugin library at `path` into `registry`, in process.
///
/// # Errors
/// A [`PluginLoadError`] naming the file and the reason, or [`PluginLoadError::Duplicate`] when the
/// registry already has a projection of that name.
pub fn load_file(registry: &mut Registry, path: &Path) -> Result<String, PluginLoadError> {
    let (factory, path) = open(path, &PluginSearch::default())?;
    register(registry, factory, path)
}

/// Opens the library at `path`: in a worker process when `search`'s isolation names it (after the
/// file checks, which run here either way), else in process. Returns the factory and the library's
/// canonical path.
fn open(
    path: &Path,
    search: &PluginSearch,
) -> Result<(Box<dyn ProjectionFactory>, PathBuf), PluginLoadError> {
    let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or_default();
    let Some(isolation) = search.isolation().filter(|i| i.applies_to(stem)) else {
        let f = PluginFactory::open(path)?;
        let path = f.path().to_path_buf();
        return Ok((Box::new(f), path));
    };
    let canonical = path.canonicalize().map_err(|e| PluginLoadError::Open {
        path: path.to_path_buf(),
        reason: e.to_string(),
    })?;
    validate::validate(&canonical)?;
    match crate::isolate::IsolatedFactory::open(&canonical, isolation) {
        #[cfg(target_os = "linux")]
        Ok(f) => Ok((Box::new(f), canonical)),
        #[cfg(not(target_os = "linux"))]
        Ok(_) => unreachable!("no isolation without Linux"),
        Err(reason) => {
            // The worker's loader names the file itself.
            let prefix = format!("{}: ", canonical.display());
            let reason = reason.strip_prefix(&prefix).map(str::to_string).unwrap_or(reason);
            Err(PluginLoadError::Isolated {
                path: canonical,
                reason,
            })
        }
    }
}

/// Registers `factory` under its name with its file's path (handed to `init` later), and returns
/// the name.
fn register(
    registry: &mut Registry,
    factory: Box<dyn ProjectionFactory>,
    path: PathBuf,
) -> Result<String, PluginLoadError> {
    let name = factory.name().to_string();
    registry
        .register(factory, &path.to_string_lossy())
        .map_err(|d| PluginLoadError::Duplicate { path, name: d.0 })?;
    Ok(name)
}

/// Loads every library along `search` ([`PluginSearch::libraries`]) into `registry` by its file's
/// name, as `obscura plugins` does to list what a user can render with. Returns the names loaded and,
/// for each library that could not be loaded, is named unlike its projection, or whose name is
/// already registered, the error naming its file; one bad library does not stop the others.
pub fn load_all(registry: &mut Registry, search: &PluginSearch) -> (Vec<String>, Vec<PluginLoadError>) {
    let (mut loaded, mut failed) = (Vec::new(), Vec::new());
    for path in search.libraries() {
        let Some(stem) = path.file_stem().and_then(|s| s.to_str()) else {
            continue;
        };
        if registry.get(stem).is_some() {
            // `<Name>.so` of a projection already known (a built-in): never reachable by name.
            failed.push(PluginLoadError::Duplicate {
                name: stem.to_string(),
                path,
            });
            continue;
        }
        // By name, exactly as `render -p <stem>` would find it: a library whose projection is not
        // named like its file is refused (it could only be used by path).
        match ensure(registry, stem, search) {
            Ok(name) => loaded.push(name),
            Err(e) => failed.push(e),
        }
    }
    (loaded, failed)
}

/// Makes sure the projection a user or a scene names is in `registry`, and returns its registered
/// name: a registered name is returned as is; a path (with a separator or a library extension) is
/// loaded; any other name is looked for as `<name>.so` along `search` and loaded.
///
/// # Errors
/// [`PluginLoadError::NotFound`] listing where it looked, with the registry's did-you-mean; or the
/// error of loading the file found.
pub fn ensure(
    registry: &mut Registry,
    name_or_path: &str,
    search: &PluginSearch,
) -> Result<String, PluginLoadError> {
    if registry.get(name_or_path).is_some() {
        return Ok(name_or_path.to_string());
    }
    if looks_like_path(name_or_path) {
        let (factory, path) = open(Path::new(name_or_path), search)?;
        return register(registry, factory, path);
    }
    let Some(path) = search.find(name_or_path) else {
        let known = registry.names();
        return Err(PluginLoadError::NotFound {
            name: name_or_path.to_string(),
            searched: search.paths().to_vec(),
            suggestion: did_you_mean(name_or_path, known.iter().map(String::as_str)),
            known,
        });
    };
    let (factory, path) = open(&path, search)?;
    if factory.name() != name_or_path {
        return Err(PluginLoadError::NameMismatch {
            path,
            expected: name_or_path.to_string(),
            found: factory.name().to_string(),
        });
    }
    register(registry, factory, path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::builtin_registry;

    #[test]
    fn an_unknown_name_lists_where_it_looked_and_what_is_known() {
        let mut reg = builtin_registry();
        let dir = tempfile::tempdir().unwrap();
        let s = PluginSearch::new(vec![dir.path().into()]);
        assert_eq!(ensure(&mut reg, "PxrPerspective", &s).unwrap(), "PxrPerspective");
        let e = ensure(&mut reg, "PxrPerspectiv", &s).unwrap_err().to_string();
        assert!(e.contains("did you mean \"PxrPerspective\""), "{e}");
        assert!(e.contains(&format!("looked in {}", dir.path().display())), "{e}");
        assert!(
            e.contains("known projections: ") && e.contains("PxrOrthographic, "),
            "{e}"
        );
        let e = ensure(&mut reg, "Nope", &PluginSearch::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("set OBSCURA_PLUGIN_PATH or pass --plugin-path"), "{e}");
    }

    #[test]
    fn a_file_that_is_not_a_library_is_refused_with_its_name() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join(library_file_name("Junk"));
        std::fs::write(&p, b"not an ELF file").unwrap();
        let mut reg = Registry::new();
        let e = load_file(&mut reg, &p).unwrap_err();
        assert!(matches!(e, PluginLoadError::Refused { .. }), "{e:?}");
        assert!(e.to_string().contains("Junk"), "{e}");
        // Refused before the system loader sees it, saying what the file is.
        assert!(
            e.to_string()
                .contains("not loaded: it is a text file (it starts \"not an ELF file\")"),
            "{e}"
        );
        let e = load_file(&mut reg, &dir.path().join("missing.so")).unwrap_err();
        assert!(e.to_string().contains("missing.so: cannot load"), "{e}");
    }
}
