//! One plugin library in this process: the file checks before the system loader sees it
//! ([`validate`]), opening it and checking its descriptor, and the adapter that makes it an ordinary
//! `ProjectionFactory` ([`PluginFactory`]).
//!
//! Both ways of running a plugin are built on this: the [`crate::loader`] opens libraries here (or
//! hands them to an isolated worker), and the worker of [`crate::isolate`] opens them here too.
//!
//! | file | what |
//! |---|---|
//! | `open.rs` | opening a library, the descriptor checks, the `init`/`finalize` session |
//! | `adapter.rs` | [`PluginFactory`] and its projections, through the function pointers |
//! | `validate.rs` | [`validate::validate`]: the file checks before `dlopen` |
//! | `error.rs` | [`PluginLoadError`] |

mod adapter;
mod error;
mod open;
pub mod validate;

pub use adapter::PluginFactory;
pub use error::PluginLoadError;
pub use open::{DESCRIPTOR_V1_SIZE, ENTRY_SYMBOL_NUL};

/// The environment variable listing plugin directories (colon-separated; `;` on Windows).
pub const PLUGIN_PATH_VAR: &str = "OBSCURA_PLUGIN_PATH";
