//! One plugin library: opened once per process and never unloaded, its descriptor checked before
//! anything in it is called, its data copied into a [`Loaded`], and its factory state shared by a
//! refcounted [`Session`] (`init` on the first user, `finalize` after the last).

use std::ffi::{CString, c_void};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, PoisonError};

use obscura_sdk::abi::c_data::read_str;
use obscura_sdk::abi::{
    self, ABI_VERSION, CreateFn, DestroyFn, EntryFn, FinalizeFn, InitFn, ProjectFn, ProjectionDescriptor,
    PropertyFn, SynchronizeFn, UnprojectFn,
};
use obscura_sdk::{ParamDecl, PluginError};

use super::PluginLoadError;
use crate::decode::decl_from_raw;
use crate::encode::collect_message;

/// [`abi::ENTRY_SYMBOL`] with its terminating NUL, as symbol lookups want it.
pub const ENTRY_SYMBOL_NUL: &[u8] = b"obscura_projection_entry\0";

/// The size of generation 1's first descriptor layout (64-bit targets: through `unproject`), the
/// smallest `struct_size` the host accepts. Fields appended within the generation lie beyond it; a
/// descriptor built with an older header is read up to its own `struct_size` and the rest is taken
/// as absent (zero: NULL pointers, no function). Pinned: it never changes within a generation.
pub const DESCRIPTOR_V1_SIZE: usize = 13 * size_of::<usize>();

// Every Option<fn> and pointer field is valid all-zero, which is what an absent appended field reads as.
const _: () = assert!(size_of::<ProjectionDescriptor>() >= DESCRIPTOR_V1_SIZE);

/// Most rows a parameter table may have: more is taken for a corrupt descriptor.
const MAX_PARAMS: usize = 4096;

/// The plugin's factory state and how many users (factories, projections) hold it.
pub(super) struct Session {
    /// Initialised factories and live projections.
    pub(super) users: usize,
    /// What `init` set; NULL while no one holds the session.
    pub(super) factory: *mut c_void,
}

/// One opened, checked library: the descriptor's data copied into the host.
pub(super) struct Loaded {
    pub(super) path: PathBuf,
    pub(super) name: String,
    pub(super) summary: String,
    pub(super) table: Vec<ParamDecl>,
    /// `Args/<Name>.args` beside the library, when there is a readable one.
    pub(super) args: Option<crate::rman::args::ArgsFile>,
    descriptor: *const ProjectionDescriptor,
    init: InitFn,
    finalize: Option<FinalizeFn>,
    pub(super) synchronize: Option<SynchronizeFn>,
    pub(super) create: CreateFn,
    pub(super) destroy: DestroyFn,
    pub(super) property: PropertyFn,
    pub(super) project: ProjectFn,
    pub(super) unproject: Option<UnprojectFn>,
    /// Serialises every factory-level call.
    pub(super) session: Mutex<Session>,
}

// SAFETY: the ABI requires `property`, `project` and `unproject` to be callable from any thread
// concurrently, and the host serialises every factory-level call through `session`. The descriptor
// pointer stays valid for the process (libraries are never unloaded).
unsafe impl Send for Loaded {}
// SAFETY: as above.
unsafe impl Sync for Loaded {}

impl Loaded {
    /// An [`PluginError::Init`] naming this plugin and its file.
    pub(super) fn init_error(&self, message: &str) -> PluginError {
        PluginError::Init {
            plugin: self.name.clone(),
            message: format!("{}: {message}", self.path.display()),
        }
    }

    /// Takes a reference on the plugin's session. Calls the plugin's `init` with `plugin_path` (the
    /// library's own path when empty) unless the session is already held.
    pub(super) fn acquire(&self, plugin_path: &str) -> Result<(), PluginError> {
        let mut s = self.session.lock().unwrap_or_else(PoisonError::into_inner);
        if s.users == 0 {
            let path = if plugin_path.is_empty() {
                self.path.to_string_lossy().into_owned()
            } else {
                plugin_path.to_string()
            };
            let path =
                CString::new(path).map_err(|_| self.init_error("the plugin path contains a NUL byte"))?;
            let mut factory = std::ptr::null_mut();
            // SAFETY: the descriptor and fn pointer were checked at load; the out-pointer and sink are
            // valid for the call.
            let (status, msg) =
                collect_message(|e| unsafe { (self.init)(self.descriptor, path.as_ptr(), &mut factory, e) });
            match status {
                abi::OK if factory.is_null() => {
                    return Err(self.init_error("init returned OK but set no factory (NULL)"));
                }
                abi::OK => s.factory = factory,
                _ => return Err(self.init_error(&or_status(msg, status))),
            }
        }
        s.users += 1;
        Ok(())
    }

    /// Drops a reference, destroying `projection` first if given; `finalize` when it was the last.
    pub(super) fn release(&self, projection: Option<*mut c_void>) {
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

/// The plugin's message, or the bare status when it sent none.
pub(super) fn or_status(msg: String, status: abi::Status) -> String {
    if msg.is_empty() {
        format!("failed with status {status} and no message")
    } else {
        msg
    }
}

/// A status as `3 (OBSCURA_PANIC)`, for messages about calls that have no error sink.
pub(super) fn status_name(status: abi::Status) -> String {
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

/// Opens and checks a plugin library (once per process per file). Runs nothing of the plugin but
/// its entry point (and the library's own initialisers, which loading any library runs).
pub(super) fn open(path: &Path) -> Result<&'static Loaded, PluginLoadError> {
    let canonical = path.canonicalize().map_err(|e| PluginLoadError::Open {
        path: path.to_path_buf(),
        reason: e.to_string(),
    })?;
    let mut cache = LOADED.lock().unwrap_or_else(PoisonError::into_inner);
    if let Some(l) = cache.iter().find(|l| l.path == canonical) {
        return Ok(l);
    }
    super::validate::validate(&canonical)?;
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
    let desc = copy_descriptor(path, d)?;
    let invalid = |reason: String| PluginLoadError::Invalid {
        path: path.to_path_buf(),
        reason,
    };
    // SAFETY: the name is NULL or NUL-terminated, by the plugin's promise.
    let name = unsafe { read_str(desc.name, "name") }
        .map_err(|_| invalid("the name is NULL or not UTF-8".into()))?;
    if name.is_empty() || name.chars().any(|c| c.is_whitespace() || c == '/' || c == '\\') {
        return Err(invalid(format!(
            "the name \"{name}\" is empty or has spaces or slashes"
        )));
    }
    let summary = if desc.summary.is_null() {
        String::new()
    } else {
        // SAFETY: as for the name.
        unsafe { read_str(desc.summary, "summary") }
            .map_err(|_| invalid("the summary is not UTF-8".into()))?
    };
    let required = |what: &str| invalid(format!("plugin {name}: the required function `{what}` is NULL"));
    let init = desc.init.ok_or_else(|| required("init"))?;
    let create = desc
        .create_projection
        .ok_or_else(|| required("create_projection"))?;
    let destroy = desc
        .destroy_projection
        .ok_or_else(|| required("destroy_projection"))?;
    let property = desc.property.ok_or_else(|| required("property"))?;
    let project = desc.project.ok_or_else(|| required("project"))?;
    let mut table = read_table(&desc, &name).map_err(invalid)?;
    let args = read_args(path, &name, &mut table);
    Ok(Loaded {
        path: path.to_path_buf(),
        name,
        summary,
        table,
        args,
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

/// The descriptor at `d`, once its version and size are known good, copied into a zeroed one.
fn copy_descriptor(
    path: &Path,
    d: *const ProjectionDescriptor,
) -> Result<ProjectionDescriptor, PluginLoadError> {
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
    let mut out = std::mem::MaybeUninit::<ProjectionDescriptor>::zeroed();
    let n = (size as usize).min(size_of::<ProjectionDescriptor>());
    // SAFETY: the plugin promises `size` readable bytes at `d`; `out` has room for `n`. All-zero
    // is a valid ProjectionDescriptor (integers, raw pointers and Option<fn> only).
    Ok(unsafe {
        std::ptr::copy_nonoverlapping(d.cast::<u8>(), out.as_mut_ptr().cast::<u8>(), n);
        out.assume_init()
    })
}

/// RenderMan's `Args/<Name>.args` beside the library at `path`: read once when the library loads,
/// its help (else label) becoming each row's documentation. A malformed file, and each parameter the
/// file and the table disagree on, is a warning on stderr naming both; the plugin loads from its table.
fn read_args(path: &Path, name: &str, table: &mut [ParamDecl]) -> Option<crate::rman::args::ArgsFile> {
    let file = crate::rman::args::args_path(path, name);
    if !file.is_file() {
        return None;
    }
    match crate::rman::args::read(&file) {
        Ok(args) => {
            for w in args.disagreements(name, path, table) {
                eprintln!("warning: {w}");
            }
            for d in table.iter_mut() {
                if let Some(p) = args.params.iter().find(|p| p.name == d.name)
                    && d.doc.is_empty()
                    && let Some(doc) = p.help.clone().or_else(|| p.label.clone())
                {
                    d.doc = doc.into();
                }
            }
            Some(args)
        }
        Err(e) => {
            eprintln!("warning: {e}; {name} loads from its own parameter table");
            None
        }
    }
}

/// The descriptor's parameter table, each row checked ([`decl_from_raw`]) and copied, no name twice.
///
/// # Errors
/// The reason the descriptor is invalid, naming the plugin, and the row or parameter.
fn read_table(desc: &ProjectionDescriptor, name: &str) -> Result<Vec<ParamDecl>, String> {
    if desc.num_params > MAX_PARAMS {
        return Err(format!(
            "plugin {name}: {} parameters (more than {MAX_PARAMS}): a corrupt descriptor?",
            desc.num_params
        ));
    }
    if desc.num_params > 0 && (desc.params.is_null() || !desc.params.is_aligned()) {
        return Err(format!(
            "plugin {name}: the parameter table is NULL or misaligned but has {} rows",
            desc.num_params
        ));
    }
    let mut table: Vec<ParamDecl> = Vec::with_capacity(desc.num_params);
    for i in 0..desc.num_params {
        // SAFETY: `num_params` rows at a non-null, aligned pointer, by the plugin's promise.
        let row = unsafe { &*desc.params.add(i) };
        // SAFETY: the row's pointers are the plugin's promise too.
        let decl = unsafe { decl_from_raw(row) }
            .map_err(|e| format!("plugin {name}: parameter table row {i}: {e}"))?;
        if table.iter().any(|d| d.name == decl.name) {
            return Err(format!(
                "plugin {name}: parameter \"{}\" is declared twice",
                decl.name
            ));
        }
        table.push(decl);
    }
    Ok(table)
}
