//! # obscura-plugins
//!
//! Where a host's projections come from:
//!
//! - [`builtins`]: the table of built-in projections, assembled from `obscura-projections` and the
//!   calibrated cameras of `obscura-calibration` ([`builtin_registry`]);
//! - [`library`]: one plugin library in this process (file checks, descriptor checks, the adapter);
//! - [`loader`]: projection plugins loaded from shared libraries through the C ABI of
//!   `include/obscura/projection.h` — the search path, the descriptor checks and the adapter that makes
//!   a plugin an ordinary [`obscura_sdk::ProjectionFactory`];
//! - [`decode`] and [`encode`]: the host's side of that ABI — reading what a plugin sends (its
//!   parameter table, its property values) and building what the host sends it (parameter lists,
//!   environments, an error sink). The plugin's side is in [`obscura_sdk::abi`], which a Rust plugin
//!   compiles in;
//! - [`isolate`]: plugins run in worker processes (`--isolate-plugins`), so a crash or hang in one
//!   costs a batch, never the host;
//! - [`listing`]: the text of `obscura plugins`;
//! - [`rman`]: RenderMan projection plugins as they are written (the C++ headers, the glue and
//!   `obscura build-plugin`).
//!
//! A host asks for a projection by name ([`loader::ensure`]): a registered name is used as is, an
//! unknown one is looked up as `<Name>.so` along the plugin path and registered. From then on a plugin
//! and a built-in go through the same [`obscura_host::Registry`] and the same camera stage.

pub mod builtins;
pub mod decode;
pub mod encode;
pub mod isolate;
pub mod library;
pub mod listing;
pub mod loader;
pub mod rman;

pub use builtins::{FILE_PROJECTIONS, builtin_registry, cli_registry, register_builtins};
pub use loader::{PluginLoadError, PluginSearch, ensure};
