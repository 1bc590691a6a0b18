//! Plugin isolation: a native plugin run in worker processes, so that its crash, abort or infinite
//! loop costs one call, never the host.
//!
//! A plugin is native code in the host's address space; a segfault in it is a segfault of the render.
//! With isolation (`--isolate-plugins`, or the plugin's name in [`ISOLATE_VAR`]) the host never loads
//! the library itself. A worker process — the `obscura` binary re-executed with the hidden argument
//! [`WORKER_ARG`] — loads it with the ordinary loader (validation included) and calls it through the
//! same adapter an in-process host uses; the host talks to the worker over a Unix socket and shares
//! each batch's arrays with it through a `memfd` mapped by both (`shm.rs`), so a batch is copied in
//! and out once and nothing is serialised per ray.
//!
//! | the plugin… | costs |
//! |---|---|
//! | crashes (SIGSEGV, SIGBUS, abort, `exit`) in `project` | that batch: counted by the camera stage as lost (`ProjectFailed` naming the signal); a new worker serves the next batch |
//! | does not return within the timeout (10 s, `--plugin-timeout`) | the same: the worker is killed |
//! | crashes in `property` or `unproject` | that answer: the callers catch the unwind as they catch a plugin's panic |
//! | crashes while loading (a constructor that aborts, an entry point that crashes) | the library: an error naming the file and the signal; other plugins are listed and used |
//! | crashes in `init` or `create_projection` | that creation: an error naming the projection |
//!
//! A worker ends when its host closes the socket, and within 0.1 s of its host's death even while
//! stuck in a plugin call (it watches its parent process), so a killed host leaves no worker spinning.
//!
//! Each rendering thread that calls the plugin at once gets a worker of its own. A worker started
//! later (a second thread, or after a crash) first replays the host's lifecycle calls — `init`,
//! `synchronize`, the projections created and destroyed, `finalize` — so every worker holds the state
//! the first one has; the plugin's own process-global state is per worker. Rays, properties and
//! parameters are the same bit for bit as in process (tests/isolate.rs holds that).
//!
//! Linux only (the shared memory is a `memfd`); elsewhere [`IsolatedFactory::open`] is a clear error.
//!
//! | file | what |
//! |---|---|
//! | `wire.rs` | the messages and their byte form |
//! | `shm.rs` | the shared memory and the batch layout in it |
//! | `process.rs` | one worker as the host sees it: start, call with a deadline, how it died |
//! | `worker.rs` | the worker's side, which [`worker_main`] runs |
//! | `factory.rs` | [`IsolatedFactory`]: the lifecycle log, the pool of workers, the projections |
//! | here | [`Isolation`] (which plugins, the timeout, the worker command) |

use std::ffi::OsString;
use std::path::PathBuf;
use std::time::Duration;

#[cfg(target_os = "linux")]
mod factory;
#[cfg(target_os = "linux")]
mod process;
#[cfg(target_os = "linux")]
mod shm;
#[cfg(target_os = "linux")]
mod wire;
#[cfg(target_os = "linux")]
mod worker;

#[cfg(target_os = "linux")]
pub use factory::IsolatedFactory;

/// The hidden first argument that makes the `obscura` binary a plugin worker.
pub const WORKER_ARG: &str = "__plugin-worker";

/// The environment variable naming the plugins to isolate: projection names separated by commas,
/// or `*` for every plugin library.
pub const ISOLATE_VAR: &str = "OBSCURA_ISOLATE_PLUGINS";

/// The environment variable through which a host tells its worker the shared memory's descriptor.
pub const SHM_FD_VAR: &str = "OBSCURA_PLUGIN_WORKER_SHM_FD";

/// The default time a plugin call may take before its worker is killed.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(10);

/// The program (and arguments) a host starts as a plugin worker.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WorkerCommand {
    /// The executable.
    pub program: PathBuf,
    /// Its arguments.
    pub args: Vec<OsString>,
}

impl WorkerCommand {
    /// This very executable with [`WORKER_ARG`]: what the `obscura` binary uses (its `main` hands that
    /// argument to [`worker_main`]).
    ///
    /// # Errors
    /// When the running executable cannot be found.
    pub fn current_exe() -> std::io::Result<Self> {
        Ok(WorkerCommand {
            program: std::env::current_exe()?,
            args: vec![WORKER_ARG.into()],
        })
    }
}

/// Which plugins run isolated, and how.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Isolation {
    /// Every plugin library (`--isolate-plugins`, or `*` in [`ISOLATE_VAR`]).
    pub all: bool,
    /// These projections (by name, which is the library's file name).
    pub names: Vec<String>,
    /// How long one call may take (`--plugin-timeout`).
    pub timeout: Duration,
    /// The worker to start.
    pub worker: WorkerCommand,
}

impl Isolation {
    /// Isolation as the command line and [`ISOLATE_VAR`] ask: `all` from `--isolate-plugins`, the
    /// variable's names (or `*`), the timeout, and this executable as the worker. `None` when nothing
    /// is isolated.
    ///
    /// # Errors
    /// When the running executable cannot be found.
    pub fn from_env(all: bool, timeout: Duration) -> std::io::Result<Option<Self>> {
        let var = std::env::var(ISOLATE_VAR).unwrap_or_default();
        let mut names: Vec<String> = var
            .split(',')
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(str::to_string)
            .collect();
        let all = all || names.iter().any(|n| n == "*");
        names.retain(|n| n != "*");
        if !all && names.is_empty() {
            return Ok(None);
        }
        Ok(Some(Isolation {
            all,
            names,
            timeout,
            worker: WorkerCommand::current_exe()?,
        }))
    }

    /// Every plugin, with `worker` and `timeout`.
    #[must_use]
    pub fn all(worker: WorkerCommand, timeout: Duration) -> Self {
        Isolation {
            all: true,
            names: Vec::new(),
            timeout,
            worker,
        }
    }

    /// True when the projection of library `stem` (its file name without extension) runs isolated.
    #[must_use]
    pub fn applies_to(&self, stem: &str) -> bool {
        self.all || self.names.iter().any(|n| n == stem)
    }
}

/// The worker's `main`: serves a host on standard input until it closes, and returns the exit code
/// (0 when the host closed the connection; 2 when not started by a host).
#[must_use]
pub fn worker_main() -> i32 {
    #[cfg(target_os = "linux")]
    {
        worker::serve()
    }
    #[cfg(not(target_os = "linux"))]
    {
        eprintln!("plugin isolation is only available on Linux");
        2
    }
}

/// Without Linux's `memfd` there is no isolation: opening an isolated plugin is an error.
#[cfg(not(target_os = "linux"))]
#[derive(Debug)]
pub struct IsolatedFactory;

#[cfg(not(target_os = "linux"))]
impl IsolatedFactory {
    /// Always an error: plugin isolation needs Linux.
    ///
    /// # Errors
    /// Always.
    pub fn open(_path: &std::path::Path, _isolation: &Isolation) -> Result<Self, String> {
        Err("plugin isolation (--isolate-plugins, OBSCURA_ISOLATE_PLUGINS) is only available on Linux".into())
    }
}
