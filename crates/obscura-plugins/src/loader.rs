//! Projection plugins from shared libraries: search, load, check, and adapt to the SDK's traits.
//!
//! A plugin is a shared library (`<Name>.so`, `.dylib` on macOS, `.dll` on Windows) exporting
//! `obscura_projection_entry` (see `include/obscura/projection.h` and [`obscura_sdk::abi`]). Loading one
//!
//! 1. opens the library (never unloaded: the [`libloading::Library`] is leaked, and a library opened
//!    twice in a process is opened once);
//! 2. looks up the entry point and calls it with the host's ABI version;
//! 3. checks the descriptor before calling anything else: not null, the same ABI version, a
//!    `struct_size` at least this version's layout, a name, the required function pointers, and a
//!    well-formed parameter table (copied into the host);
//! 4. calls `init` once, so a failing plugin is reported when it is loaded, naming the file;
//! 5. registers a [`PluginFactory`] — an ordinary [`ProjectionFactory`] — in the [`Registry`], so a
//!    loaded projection goes through the same camera stage, validation and culling as a built-in.
//!
//! [`ensure`] is what the CLI calls with a name from the user or a scene: a registered name is used as
//! is, a path is loaded, and an unknown name is looked up as `<Name>.so` along [`PluginSearch`]
//! (`--plugin-path` directories, then `OBSCURA_PLUGIN_PATH`).
//!
//! A status other than OK from the plugin's `project` (a caught panic, an error) becomes a panic in
//! [`Projection::project`] (raised with `resume_unwind`, so no second panic message is printed); the
//! camera stage already catches that, culls and counts the batch's samples, and the render goes on.
//! The same holds for `property` and `unproject`: a failed call (any status but OK and UNSUPPORTED)
//! is raised, never passed off as "unanswered" or "outside the view", and a property value that does
//! not decode is raised as an [`UndecodableProperty`]. Every caller catches them: the camera stage's
//! property reader warns and goes on without the property, `stmap` counts the pixels, and
//! `obscura check` reports a panic or a property of the wrong type.

use std::ffi::{CString, c_char, c_void};
use std::panic::resume_unwind;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, PoisonError};

use obscura_sdk::abi::{
    self, ABI_VERSION, CreateFn, DESCRIPTOR_V1_SIZE, DestroyFn, ENTRY_SYMBOL, ENTRY_SYMBOL_NUL, EntryFn,
    FinalizeFn, InitFn, OwnedEnvironment, OwnedParamList, ProjectFn, ProjectionDescriptor, PropertyFn,
    RawContext, RawPropertyValue, SynchronizeFn, UnprojectFn, collect_message,
};
use obscura_sdk::contract::{ProjectFailed, UndecodableProperty};
use obscura_sdk::{
    ParamDecl, ParamList, Params, PluginError, Point2, Projection, ProjectionContext, ProjectionEnvironment,
    ProjectionFactory, ProjectionProperty, PropertyValue, Registry, SyncMessage, Vec3, did_you_mean,
};

/// The environment variable listing plugin directories (colon-separated; `;` on Windows).
pub const PLUGIN_PATH_VAR: &str = "OBSCURA_PLUGIN_PATH";

/// Most rows a parameter table may have: more is taken for a corrupt descriptor.
const MAX_PARAMS: usize = 4096;

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
    /// `init` failed.
    #[error("{}: plugin {name} failed to initialise: {message}", path.display())]
    Init {
        /// The file.
        path: PathBuf,
        /// The plugin.
        name: String,
        /// The plugin's message.
        message: String,
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

/// Where plugin libraries are looked for, in order.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct PluginSearch {
    paths: Vec<PathBuf>,
}

impl PluginSearch {
    /// Searches exactly these directories, in order.
    #[must_use]
    pub fn new(paths: Vec<PathBuf>) -> Self {
        PluginSearch { paths }
    }

    /// `extra` (the CLI's `--plugin-path`, most specific first), then every directory of
    /// `OBSCURA_PLUGIN_PATH`.
    #[must_use]
    pub fn from_env(extra: &[PathBuf]) -> Self {
        let env = std::env::var_os(PLUGIN_PATH_VAR);
        Self::from_parts(extra, env.as_deref())
    }

    /// [`PluginSearch::from_env`] with the variable's value given (tests, tools).
    #[must_use]
    pub fn from_parts(extra: &[PathBuf], plugin_path: Option<&std::ffi::OsStr>) -> Self {
        let mut paths: Vec<PathBuf> = extra.to_vec();
        if let Some(v) = plugin_path {
            paths.extend(std::env::split_paths(v).filter(|p| !p.as_os_str().is_empty()));
        }
        PluginSearch { paths }
    }

    /// The directories, in search order.
    #[must_use]
    pub fn paths(&self) -> &[PathBuf] {
        &self.paths
    }

    /// Every plugin library along the path: each `*.so` (`.dylib`, `.dll`) file of each directory,
    /// sorted by file name, and only the first of a file name (the one `find` would take).
    /// Directories that cannot be read are skipped.
    #[must_use]
    pub fn libraries(&self) -> Vec<PathBuf> {
        let mut seen = std::collections::HashSet::new();
        let mut found = Vec::new();
        for dir in &self.paths {
            let Ok(entries) = std::fs::read_dir(dir) else {
                continue;
            };
            let mut here: Vec<PathBuf> = entries
                .filter_map(Result::ok)
                .map(|e| e.path())
                .filter(|p| p.is_file())
                .filter(|p| {
                    p.extension()
                        .is_some_and(|e| e == std::env::consts::DLL_EXTENSION)
                })
                .collect();
            here.sort();
            for p in here {
                if let Some(file) = p.file_name().map(std::ffi::OsStr::to_os_string)
                    && seen.insert(file)
                {
                    found.push(p);
                }
            }
        }
        found
    }

    /// The first `<name>.so` (`.dylib`, `.dll`) along the path that exists.
    #[must_use]
    pub fn find(&self, name: &str) -> Option<PathBuf> {
        let file = library_file_name(name);
        self.paths.iter().map(|d| d.join(&file)).find(|p| p.is_file())
    }
}

/// `<name>.so` on Linux, `<name>.dylib` on macOS, `<name>.dll` on Windows.
#[must_use]
pub fn library_file_name(name: &str) -> String {
    format!("{name}.{}", std::env::consts::DLL_EXTENSION)
}

/// True when `s` names a file rather than a projection: it has a path separator or a library
/// extension.
#[must_use]
pub fn looks_like_path(s: &str) -> bool {
    s.contains('/')
        || s.contains(std::path::MAIN_SEPARATOR)
        || [".so", ".dylib", ".dll"].iter().any(|e| s.ends_with(e))
}

/// The plugin's factory state and how many users (factories, projections) hold it.
struct Session {
    users: usize,
    factory: *mut c_void,
}

/// One opened, checked library: the descriptor's data copied into the host.
struct Loaded {
    path: PathBuf,
    name: String,
    summary: String,
    table: Vec<ParamDecl>,
    descriptor: *const ProjectionDescriptor,
    init: InitFn,
    finalize: Option<FinalizeFn>,
    synchronize: Option<SynchronizeFn>,
    create: CreateFn,
    destroy: DestroyFn,
    property: PropertyFn,
    project: ProjectFn,
    unproject: Option<UnprojectFn>,
    session: Mutex<Session>,
}

// SAFETY: the ABI requires `property`, `project` and `unproject` to be callable from any thread
// concurrently, and the host serialises every factory-level call through `session`. The descriptor
// pointer stays valid for the process (libraries are never unloaded).
unsafe impl Send for Loaded {}
// SAFETY: as above.
unsafe impl Sync for Loaded {}

impl Loaded {
    /// Takes a reference on the plugin's session, calling `init` when it is the first.
    /// Calls the plugin's `init` with `plugin_path` (the library's own path when empty) unless another
    /// factory of this library already did.
    fn acquire(&self, plugin_path: &str) -> Result<(), String> {
        let mut s = self.session.lock().unwrap_or_else(PoisonError::into_inner);
        if s.users == 0 {
            let path = if plugin_path.is_empty() {
                self.path.to_string_lossy().into_owned()
            } else {
                plugin_path.to_string()
            };
            let path = CString::new(path).map_err(|_| "the plugin path contains a NUL byte".to_string())?;
            let mut factory = std::ptr::null_mut();
            // SAFETY: the descriptor and fn pointer were checked at load; the out-pointer and sink are
            // valid for the call.
            let (status, msg) =
                collect_message(|e| unsafe { (self.init)(self.descriptor, path.as_ptr(), &mut factory, e) });
            match status {
                abi::OK if factory.is_null() => {
                    return Err("init returned OK but set no factory (NULL)".into());
                }
                abi::OK => s.factory = factory,
                _ => return Err(or_status(msg, status)),
            }
        }
        s.users += 1;
        Ok(())
    }

    /// Drops a reference, destroying `projection` first if given; `finalize` when it was the last.
    fn release(&self, projection: Option<*mut c_void>) {
        let mut s = self.session.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(p) = projection {
            // SAFETY: `p` came from this plugin's `create_projection` and is destroyed once.
            unsafe { (self.destroy)(s.factory, p) };
        }
        s.users = s.users.saturating_sub(1);
        if s.users == 0 && !s.factory.is_null() {
            if let Some(f) = self.finalize {
                // SAFETY: the factory `init` made; every projection is already destroyed.
                unsafe { f(s.factory) };
            }
            s.factory = std::ptr::null_mut();
        }
    }
}

fn or_status(msg: String, status: abi::Status) -> String {
    if msg.is_empty() {
        format!("failed with status {status} and no message")
    } else {
        msg
    }
}

/// A status as `3 (OBSCURA_PANIC)`, for messages about calls that have no error sink.
fn status_name(status: abi::Status) -> String {
    let name = match status {
        abi::OK => "OBSCURA_OK",
        abi::UNSUPPORTED => "OBSCURA_UNSUPPORTED",
        abi::ERROR => "OBSCURA_ERROR",
        abi::PANIC => "OBSCURA_PANIC: a panic or exception caught in the plugin",
        _ => "not a status of the ABI",
    };
    format!("{status} ({name})")
}

/// Every library this process has opened, by canonical path. Leaked: libraries are never unloaded.
static LOADED: Mutex<Vec<&'static Loaded>> = Mutex::new(Vec::new());

/// An error with its sources: libloading's own text is only "dlopen failed"; the system loader's
/// reason ("file too short", "wrong ELF class") is its source.
fn error_chain(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        let more = s.to_string();
        if !text.contains(&more) {
            text = format!("{text}: {more}");
        }
        source = s.source();
    }
    text
}

/// Opens and checks a plugin library (once per process per file).
fn open(path: &Path) -> Result<&'static Loaded, PluginLoadError> {
    let canonical = path.canonicalize().map_err(|e| PluginLoadError::Open {
        path: path.to_path_buf(),
        reason: e.to_string(),
    })?;
    let mut cache = LOADED.lock().unwrap_or_else(PoisonError::into_inner);
    if let Some(l) = cache.iter().find(|l| l.path == canonical) {
        return Ok(l);
    }
    // SAFETY: loading a library runs its initialisers; that is what loading a plugin means. The
    // library is leaked below, so nothing it hands out ever dangles.
    let lib = unsafe { libloading::Library::new(&canonical) }.map_err(|e| PluginLoadError::Open {
        path: canonical.clone(),
        reason: error_chain(&e),
    })?;
    let lib: &'static libloading::Library = Box::leak(Box::new(lib));
    // SAFETY: the symbol's type is the ABI's entry point type.
    let entry: EntryFn = unsafe { lib.get::<EntryFn>(ENTRY_SYMBOL_NUL) }
        .map(|s| *s)
        .map_err(|e| PluginLoadError::MissingSymbol {
            path: canonical.clone(),
            reason: e.to_string(),
        })?;
    // SAFETY: calling the entry point the ABI defines.
    let d = unsafe { entry(ABI_VERSION) };
    let loaded = check_descriptor(&canonical, d)?;
    let loaded: &'static Loaded = Box::leak(Box::new(loaded));
    cache.push(loaded);
    Ok(loaded)
}

/// The checks a descriptor passes before the host calls anything in it.
fn check_descriptor(path: &Path, d: *const ProjectionDescriptor) -> Result<Loaded, PluginLoadError> {
    let path = path.to_path_buf();
    if d.is_null() {
        return Err(PluginLoadError::NullDescriptor {
            path,
            host: ABI_VERSION,
        });
    }
    if !d.is_aligned() {
        return Err(PluginLoadError::Invalid {
            path,
            reason: "the descriptor pointer is misaligned".into(),
        });
    }
    // Every version's descriptor starts with the two u32s `abi_version` and `struct_size`: read only
    // those until both are known good.
    // SAFETY: non-null, aligned, and at least 8 bytes in every layout generation.
    let (version, size) = unsafe {
        let head = d.cast::<u32>();
        (head.read(), head.add(1).read())
    };
    if version != ABI_VERSION {
        return Err(PluginLoadError::Version {
            path,
            found: version,
            expected: ABI_VERSION,
        });
    }
    if (size as usize) < DESCRIPTOR_V1_SIZE {
        return Err(PluginLoadError::Size {
            path,
            found: size,
            minimum: DESCRIPTOR_V1_SIZE,
            version,
        });
    }
    // A plugin built with an older header of this generation has a shorter descriptor: copy what it
    // has into a zeroed one, so fields appended since read as absent (NULL, no function).
    let desc = {
        let mut out = std::mem::MaybeUninit::<ProjectionDescriptor>::zeroed();
        let n = (size as usize).min(size_of::<ProjectionDescriptor>());
        // SAFETY: the plugin promises `size` readable bytes at `d`; `out` has room for `n`. All-zero
        // is a valid ProjectionDescriptor (integers, raw pointers and Option<fn> only).
        unsafe {
            std::ptr::copy_nonoverlapping(d.cast::<u8>(), out.as_mut_ptr().cast::<u8>(), n);
            out.assume_init()
        }
    };
    let invalid = |reason: String| PluginLoadError::Invalid {
        path: path.clone(),
        reason,
    };
    let name = read_c_str(desc.name).ok_or_else(|| invalid("the name is NULL or not UTF-8".into()))?;
    if name.is_empty() || name.chars().any(|c| c.is_whitespace() || c == '/' || c == '\\') {
        return Err(invalid(format!(
            "the name \"{name}\" is empty or has spaces or slashes"
        )));
    }
    let summary = if desc.summary.is_null() {
        String::new()
    } else {
        read_c_str(desc.summary).ok_or_else(|| invalid("the summary is not UTF-8".into()))?
    };
    let required = |f: bool, what: &str| {
        if f {
            Ok(())
        } else {
            Err(invalid(format!(
                "plugin {name}: the required function `{what}` is NULL"
            )))
        }
    };
    required(desc.init.is_some(), "init")?;
    required(desc.create_projection.is_some(), "create_projection")?;
    required(desc.destroy_projection.is_some(), "destroy_projection")?;
    required(desc.property.is_some(), "property")?;
    required(desc.project.is_some(), "project")?;
    if desc.num_params > MAX_PARAMS {
        return Err(invalid(format!(
            "plugin {name}: {} parameters (more than {MAX_PARAMS}): a corrupt descriptor?",
            desc.num_params
        )));
    }
    if desc.num_params > 0 && (desc.params.is_null() || !desc.params.is_aligned()) {
        return Err(invalid(format!(
            "plugin {name}: the parameter table is NULL or misaligned but has {} rows",
            desc.num_params
        )));
    }
    let mut table: Vec<ParamDecl> = Vec::with_capacity(desc.num_params);
    for i in 0..desc.num_params {
        // SAFETY: `num_params` rows at a non-null, aligned pointer, by the plugin's promise.
        let row = unsafe { &*desc.params.add(i) };
        // SAFETY: the row's pointers are the plugin's promise too.
        let decl = unsafe { abi::decl_from_raw(row) }
            .map_err(|e| invalid(format!("plugin {name}: parameter table row {i}: {e}")))?;
        if table.iter().any(|d| d.name == decl.name) {
            return Err(invalid(format!(
                "plugin {name}: parameter \"{}\" is declared twice",
                decl.name
            )));
        }
        table.push(decl);
    }
    let (Some(init), Some(create), Some(destroy), Some(property), Some(project)) = (
        desc.init,
        desc.create_projection,
        desc.destroy_projection,
        desc.property,
        desc.project,
    ) else {
        unreachable!("checked just above");
    };
    Ok(Loaded {
        path,
        name,
        summary,
        table,
        descriptor: d,
        init,
        finalize: desc.finalize,
        synchronize: desc.synchronize,
        create,
        destroy,
        property,
        project,
        unproject: desc.unproject,
        session: Mutex::new(Session {
            users: 0,
            factory: std::ptr::null_mut(),
        }),
    })
}

fn read_c_str(p: *const c_char) -> Option<String> {
    if p.is_null() {
        return None;
    }
    // SAFETY: non-null and NUL-terminated by the plugin's promise.
    unsafe { std::ffi::CStr::from_ptr(p) }
        .to_str()
        .ok()
        .map(str::to_string)
}

/// A loaded plugin's factory: a [`ProjectionFactory`] calling through the C ABI.
pub struct PluginFactory {
    lib: &'static Loaded,
    initialized: bool,
}

impl std::fmt::Debug for PluginFactory {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PluginFactory")
            .field("name", &self.lib.name)
            .field("path", &self.lib.path)
            .finish()
    }
}

impl PluginFactory {
    /// Opens the library at `path` and checks its descriptor. The plugin's `init` is not called here:
    /// the registry calls it, with the library's path, before the first projection is created, so
    /// listing or loading a plugin runs none of its code but the entry point.
    ///
    /// # Errors
    /// A [`PluginLoadError`] naming the file and the reason.
    pub fn open(path: &Path) -> Result<Self, PluginLoadError> {
        Ok(PluginFactory {
            lib: open(path)?,
            initialized: false,
        })
    }

    /// The library's file (canonical path).
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.lib.path
    }
}

impl ProjectionFactory for PluginFactory {
    fn name(&self) -> &str {
        &self.lib.name
    }

    fn summary(&self) -> &str {
        &self.lib.summary
    }

    fn param_table(&self) -> &[ParamDecl] {
        &self.lib.table
    }

    fn init(&mut self, plugin_path: &str) -> Result<(), PluginError> {
        if !self.initialized {
            self.lib
                .acquire(plugin_path)
                .map_err(|message| PluginError::Init {
                    plugin: self.lib.name.clone(),
                    message: format!("{}: {message}", self.lib.path.display()),
                })?;
            self.initialized = true;
        }
        Ok(())
    }

    fn finalize(&mut self) {
        if std::mem::take(&mut self.initialized) {
            self.lib.release(None);
        }
    }

    fn synchronize(&mut self, message: SyncMessage, params: Option<&ParamList>) {
        let Some(sync) = self.lib.synchronize else {
            return;
        };
        // A list that does not fit the table reaches the plugin as NULL; create reports the error.
        let list = params
            .filter(|p| Params::resolve(&self.lib.name, &self.lib.table, p).is_ok())
            .and_then(|p| OwnedParamList::new(&self.lib.table, p).ok());
        let s = self.lib.session.lock().unwrap_or_else(PoisonError::into_inner);
        if s.factory.is_null() {
            return;
        }
        let raw = list.as_ref().map_or(std::ptr::null(), |l| l.raw() as *const _);
        // SAFETY: the factory `init` made, a valid (or null) list, serialised by the session lock.
        unsafe { sync(s.factory, message as i32, raw) };
    }

    fn create_projection(
        &self,
        env: &mut ProjectionEnvironment,
        params: &ParamList,
    ) -> Result<Box<dyn Projection>, PluginError> {
        let name = &self.lib.name;
        let invalid = |message: String| PluginError::Invalid {
            plugin: name.clone(),
            message,
        };
        Params::resolve(name, &self.lib.table, params)?;
        let list = OwnedParamList::new(&self.lib.table, params).map_err(invalid)?;
        let mut raw_env = OwnedEnvironment::new(env);
        let mut s = self.lib.session.lock().unwrap_or_else(PoisonError::into_inner);
        if s.factory.is_null() {
            return Err(PluginError::Init {
                plugin: name.clone(),
                message: format!("{}: create_projection before init", self.lib.path.display()),
            });
        }
        let mut handle = std::ptr::null_mut();
        // SAFETY: the factory `init` made; the environment, list, out-pointer and sink live for the
        // call; factory calls are serialised by the session lock.
        let (status, msg) = collect_message(|e| unsafe {
            (self.lib.create)(s.factory, raw_env.raw_mut(), list.raw(), &mut handle, e)
        });
        let prefix = format!("{name}: ");
        let msg = msg.strip_prefix(&prefix).map(str::to_string).unwrap_or(msg);
        match status {
            abi::OK if handle.is_null() => {
                return Err(invalid(
                    "create_projection returned OK but no projection (NULL)".into(),
                ));
            }
            abi::OK => {}
            _ => return Err(invalid(or_status(msg, status))),
        }
        match raw_env.deep_metric() {
            Ok(m) => env.set_deep_metric(m),
            Err(e) => {
                // SAFETY: just created, destroyed once.
                unsafe { (self.lib.destroy)(s.factory, handle) };
                return Err(invalid(e));
            }
        }
        s.users += 1;
        Ok(Box::new(PluginProjection {
            lib: self.lib,
            handle,
        }))
    }
}

impl Drop for PluginFactory {
    fn drop(&mut self) {
        self.finalize();
    }
}

/// A projection made by a loaded plugin.
struct PluginProjection {
    lib: &'static Loaded,
    handle: *mut c_void,
}

// SAFETY: the ABI requires a projection's `property`, `project` and `unproject` to be thread-safe.
unsafe impl Send for PluginProjection {}
// SAFETY: as above.
unsafe impl Sync for PluginProjection {}

impl Projection for PluginProjection {
    fn property(&self, property: ProjectionProperty) -> Option<PropertyValue> {
        let mut v = RawPropertyValue {
            kind: -1,
            enum_value: 0,
            float_value: 0.0,
        };
        // SAFETY: a live projection handle and an out-pointer valid for the call.
        let status = unsafe { (self.lib.property)(self.handle, property as i32, &mut v) };
        match status {
            abi::OK => match abi::value_from_raw(v) {
                Ok(v) => Some(v),
                // Not `None`: the reader catches this and warns, `obscura check` counts a wrong type.
                Err(reason) => resume_unwind(Box::new(UndecodableProperty {
                    property: property.renderman_name(),
                    reason,
                })),
            },
            abi::UNSUPPORTED => None,
            s => resume_unwind(Box::new(format!("the plugin returned status {}", status_name(s)))),
        }
    }

    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        let c = ctx.parts_mut();
        let n = c.screen.len();
        let mut start = 0;
        while start < n {
            let end = n.min(start + u32::MAX as usize);
            let raw = RawContext {
                struct_size: size_of::<RawContext>() as u32,
                num_rays: (end - start) as u32,
                screen: c.screen[start..].as_ptr(),
                lens: c.lens[start..].as_ptr(),
                aperture: c.aperture[start..].as_ptr(),
                time: c.time[start..].as_mut_ptr(),
                rays: c.rays[start..].as_mut_ptr(),
                tint: c.tint[start..].as_mut_ptr(),
            };
            // SAFETY: every array holds `num_rays` elements from `start` and is lent for the call.
            let (status, msg) = collect_message(|e| unsafe { (self.lib.project)(self.handle, &raw, e) });
            // The camera stage catches these, culls and counts the batch; `resume_unwind` skips the
            // panic hook, which already spoke in the plugin if it was a Rust panic.
            match status {
                abi::OK => {}
                abi::ERROR => resume_unwind(Box::new(ProjectFailed(or_status(msg, status)))),
                abi::PANIC => resume_unwind(Box::new(
                    msg.strip_prefix("panicked in project: ")
                        .map(str::to_string)
                        .unwrap_or(msg),
                )),
                _ => resume_unwind(Box::new(format!("project failed: {}", or_status(msg, status)))),
            }
            start = end;
        }
    }

    fn unproject(&self, point: Vec3, time: f32) -> Option<Point2> {
        let f = self.lib.unproject?;
        let mut out = Point2::ZERO;
        // SAFETY: a live projection handle and an out-pointer valid for the call.
        let status = unsafe { f(self.handle, point, time, &mut out) };
        match status {
            abi::OK => Some(out),
            abi::UNSUPPORTED => None,
            // A failure is not "outside the view": callers catch this and count it.
            s => resume_unwind(Box::new(format!("the plugin returned status {}", status_name(s)))),
        }
    }
}

impl Drop for PluginProjection {
    fn drop(&mut self) {
        self.lib.release(Some(self.handle));
    }
}

/// Loads the plugin library at `path` into `registry`.
///
/// # Errors
/// A [`PluginLoadError`] naming the file and the reason, or [`PluginLoadError::Duplicate`] when the
/// registry already has a projection of that name.
pub fn load_file(registry: &mut Registry, path: &Path) -> Result<String, PluginLoadError> {
    let factory = PluginFactory::open(path)?;
    let name = factory.name().to_string();
    if registry.get(&name).is_some() {
        return Err(PluginLoadError::Duplicate {
            path: factory.path().to_path_buf(),
            name,
        });
    }
    let file = factory.path().to_string_lossy().into_owned();
    let dup_path = factory.path().to_path_buf();
    registry
        .register(Box::new(factory), &file)
        .map_err(|d| PluginLoadError::Duplicate {
            path: dup_path,
            name: d.0,
        })?;
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
        return load_file(registry, Path::new(name_or_path));
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
    let factory = PluginFactory::open(&path)?;
    if factory.name() != name_or_path {
        return Err(PluginLoadError::NameMismatch {
            path: factory.path().to_path_buf(),
            expected: name_or_path.to_string(),
            found: factory.name().to_string(),
        });
    }
    let file = factory.path().to_string_lossy().into_owned();
    registry
        .register(Box::new(factory), &file)
        .map_err(|d| PluginLoadError::Duplicate {
            path: path.clone(),
            name: d.0,
        })?;
    Ok(name_or_path.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::builtin_registry;

    #[test]
    fn the_command_line_comes_before_the_environment_and_empty_entries_are_skipped() {
        let sep = if cfg!(windows) { ";" } else { ":" };
        let var = format!("/a{sep}{sep}/b");
        let s = PluginSearch::from_parts(&[PathBuf::from("/cli")], Some(std::ffi::OsStr::new(&var)));
        assert_eq!(
            s.paths(),
            &[PathBuf::from("/cli"), PathBuf::from("/a"), PathBuf::from("/b")]
        );
    }

    #[test]
    fn a_search_finds_the_first_file_named_after_the_projection() {
        let a = tempfile::tempdir().unwrap();
        let b = tempfile::tempdir().unwrap();
        std::fs::write(b.path().join(library_file_name("Foo")), b"").unwrap();
        let s = PluginSearch::new(vec![a.path().into(), b.path().into()]);
        assert_eq!(s.find("Foo"), Some(b.path().join(library_file_name("Foo"))));
        assert_eq!(s.find("Bar"), None);
    }

    #[test]
    fn paths_are_told_from_names() {
        assert!(looks_like_path("./x.so") && looks_like_path("x.dylib") && looks_like_path("a/b"));
        assert!(!looks_like_path("PxrPerspective"));
    }

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
        assert!(matches!(e, PluginLoadError::Open { .. }), "{e:?}");
        assert!(e.to_string().contains("Junk"), "{e}");
        // The system loader's reason, not only libloading's "dlopen failed".
        #[cfg(target_os = "linux")]
        assert!(e.to_string().contains("file too short"), "{e}");
        let e = load_file(&mut reg, &dir.path().join("missing.so")).unwrap_err();
        assert!(e.to_string().contains("missing.so: cannot load"), "{e}");
    }
}
