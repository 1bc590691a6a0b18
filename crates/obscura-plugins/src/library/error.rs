//! [`PluginLoadError`]: why a plugin library could not be found, loaded or trusted.

use std::path::PathBuf;

use obscura_sdk::abi::ENTRY_SYMBOL;

use super::PLUGIN_PATH_VAR;

/// A plugin library could not be found, loaded or trusted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PluginLoadError {
    /// The file could not be opened as a shared library.
    #[error("{}: cannot load the library: {reason}", path.display())]
    Open {
        /// The file.
        path: PathBuf,
        /// The loader's reason.
        reason: String,
    },
    /// The file was refused before the system loader saw it: not a shared library of this host,
    /// truncated, or an entry point that is not a function (see [`super::validate`]).
    #[error("{}: not loaded: {reason}", path.display())]
    Refused {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        reason: String,
    },
    /// The plugin's worker process (`--isolate-plugins`) failed: it crashed or hung while loading or
    /// describing the library, or could not be started.
    #[error("{}: {reason}", path.display())]
    Isolated {
        /// The file.
        path: PathBuf,
        /// What happened.
        reason: String,
    },
    /// The library does not export the entry point.
    #[error("{}: not an Obscura projection plugin: it does not export `{}` ({reason})", path.display(), ENTRY_SYMBOL)]
    MissingSymbol {
        /// The file.
        path: PathBuf,
        /// The loader's reason.
        reason: String,
    },
    /// The entry point returned a null descriptor.
    #[error("{}: `{}` returned NULL: the plugin refused this host (projection ABI version {host}) or could not build its descriptor (see any message it printed above)", path.display(), ENTRY_SYMBOL)]
    NullDescriptor {
        /// The file.
        path: PathBuf,
        /// The version the host asked for.
        host: u32,
    },
    /// The plugin was built for another ABI version.
    #[error("{}: built for projection ABI version {found}, but this host speaks version {expected}; rebuild the plugin against this host's include/obscura/projection.h (or obscura-sdk)", path.display())]
    Version {
        /// The file.
        path: PathBuf,
        /// The plugin's version.
        found: u32,
        /// The host's version.
        expected: u32,
    },
    /// The descriptor is smaller than its version's layout.
    #[error("{}: the descriptor's struct_size is {found} bytes, but ABI version {version} needs at least {minimum}: the plugin was built with a mismatched header", path.display())]
    Size {
        /// The file.
        path: PathBuf,
        /// The plugin's `struct_size`.
        found: u32,
        /// The layout's size.
        minimum: usize,
        /// The ABI version.
        version: u32,
    },
    /// The descriptor is malformed: a null required pointer, a bad name or parameter table.
    #[error("{}: invalid descriptor: {reason}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// A search found a file whose plugin has another name.
    #[error("{}: this library is projection \"{found}\", not \"{expected}\" (name the file {found}.{})", path.display(), std::env::consts::DLL_EXTENSION)]
    NameMismatch {
        /// The file.
        path: PathBuf,
        /// The name searched for.
        expected: String,
        /// The name the plugin gives.
        found: String,
    },
    /// The registry already holds a projection of the plugin's name.
    #[error("{}: a projection named \"{name}\" is already registered", path.display())]
    Duplicate {
        /// The file.
        path: PathBuf,
        /// The name.
        name: String,
    },
    /// No registered projection and no plugin file of that name.
    #[error("unknown projection \"{name}\"{hint}: not built in, and no {name}.{ext} in the plugin path ({where_}); known projections: {known}",
        hint = suggestion.as_ref().map(|s| format!(" (did you mean \"{s}\"?)")).unwrap_or_default(),
        ext = std::env::consts::DLL_EXTENSION,
        where_ = if searched.is_empty() {
            format!("empty: set {PLUGIN_PATH_VAR} or pass --plugin-path")
        } else {
            format!("looked in {}", searched.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", "))
        },
        known = known.join(", "))]
    NotFound {
        /// The name asked for.
        name: String,
        /// The directories searched.
        searched: Vec<PathBuf>,
        /// The closest registered name.
        suggestion: Option<String>,
        /// Every registered name.
        known: Vec<String>,
    },
}
