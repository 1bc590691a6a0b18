//! [`IsolatedFactory`]: a plugin whose code runs only in worker processes, as an ordinary
//! [`ProjectionFactory`].
//!
//! The factory keeps a log of the lifecycle calls the host made (`init`, `synchronize`, each
//! `create_projection` that succeeded, each projection dropped, `finalize`). Every worker replays the
//! log before it serves a call, so a worker started after a crash — or a second worker serving a
//! second rendering thread — holds the same factory state and projections as the first. Calls that
//! can fail (`init`, `create_projection`) run on one worker first and enter the log only if they
//! succeeded; the others (`synchronize`, destroying, `finalize`) enter the log and reach every idle
//! worker at once, so a plugin hears `RenderEnd` when the host says it.
//!
//! `project`, `property` and `unproject` take an idle worker (or start one), run there, and give it
//! back. When the worker dies or hangs, the call unwinds like a plugin's own failure — `project` with
//! a [`ProjectFailed`] naming what happened, which the camera stage counts as a lost batch — and the
//! next call starts a new worker.

use std::panic::resume_unwind;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

use obscura_host::contract::{ProjectFailed, UndecodableProperty};
use obscura_sdk::{
    ParamDecl, ParamList, Params, PluginError, Point2, Projection, ProjectionContext, ProjectionEnvironment,
    ProjectionFactory, ProjectionProperty, PropertyValue, SyncMessage, Vec3,
};

use super::Isolation;
use super::process::{Death, Worker};
use super::wire::{Description, Reply, Request};

/// One lifecycle call, as the log keeps it.
#[derive(Debug, Clone)]
enum Event {
    Init(String),
    Sync(SyncMessage, Option<ParamList>),
    Create(u64, ProjectionEnvironment, ParamList),
    Destroy(u64),
    Finalize,
}

impl Event {
    /// The call, for messages.
    fn name(&self) -> String {
        match self {
            Event::Init(_) => "init".into(),
            Event::Sync(m, _) => format!("synchronize({m:?})"),
            Event::Create(..) => "create_projection".into(),
            Event::Destroy(_) => "destroy_projection".into(),
            Event::Finalize => "finalize".into(),
        }
    }

    fn request(&self) -> Request {
        match self {
            Event::Init(p) => Request::Init(p.clone()),
            Event::Sync(m, l) => Request::Sync(*m, l.clone()),
            Event::Create(id, env, l) => Request::Create(*id, env.clone(), l.clone()),
            Event::Destroy(id) => Request::Destroy(*id),
            Event::Finalize => Request::Finalize,
        }
    }
}

/// What the factory and its projections share.
struct Shared {
    path: PathBuf,
    description: Description,
    isolation: Isolation,
    /// The lifecycle so far. Lock order: `log`, then `idle`.
    log: Mutex<Vec<Event>>,
    /// Workers not serving a call.
    idle: Mutex<Vec<Worker>>,
    next_id: AtomicU64,
    /// Workers that crashed, hung or broke.
    deaths: AtomicU64,
    /// New workers in a row that could not be brought up, and the last reason.
    failed_starts: Mutex<(u32, String)>,
}

/// New workers in a row that may fail to come up (a plugin whose `init` now crashes every time)
/// before the factory stops starting them: each later call fails at once instead of paying a start.
const MAX_FAILED_STARTS: u32 = 3;

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

impl Shared {
    /// An idle worker brought up to date with `log`, or a new one.
    fn take(&self, log: &[Event]) -> Result<Worker, String> {
        let idle = lock(&self.idle).pop();
        if let Some(mut w) = idle {
            self.catch_up(&mut w, log)?;
            return Ok(w);
        }
        let mut failed = lock(&self.failed_starts);
        if failed.0 >= MAX_FAILED_STARTS {
            return Err(format!(
                "no worker is started any more: the last {MAX_FAILED_STARTS} could not be brought up ({})",
                failed.1
            ));
        }
        let started = self.start(log);
        match &started {
            Ok(_) => failed.0 = 0,
            Err(why) => *failed = (failed.0 + 1, why.clone()),
        }
        started
    }

    /// A new worker, caught up with `log`.
    fn start(&self, log: &[Event]) -> Result<Worker, String> {
        let (mut w, d) = Worker::spawn(&self.isolation.worker, &self.path, self.isolation.timeout)?;
        if d.name != self.description.name {
            return Err(format!(
                "a new worker found projection \"{}\" in the library, not \"{}\": was the file replaced?",
                d.name, self.description.name
            ));
        }
        self.catch_up(&mut w, log)?;
        Ok(w)
    }

    /// Replays the events `w` has not seen.
    fn catch_up(&self, w: &mut Worker, log: &[Event]) -> Result<(), String> {
        while let Some(event) = log.get(w.replayed) {
            match w.call(&event.request(), self.isolation.timeout) {
                Ok(Reply::Done | Reply::Created(_)) => w.replayed += 1,
                Ok(Reply::Plugin(e)) => {
                    return Err(format!("replaying {} in a new worker: {e}", event.name()));
                }
                Ok(other) => {
                    return Err(format!("replaying {} in a new worker: {other:?}", event.name()));
                }
                Err(death) => {
                    self.deaths.fetch_add(1, Ordering::Relaxed);
                    return Err(format!("{death} while catching up with the host"));
                }
            }
        }
        Ok(())
    }

    /// Gives a worker back (bringing it up to date with what happened while it was busy).
    fn give_back(&self, mut w: Worker) {
        let log = lock(&self.log);
        if self.catch_up(&mut w, &log).is_ok() {
            lock(&self.idle).push(w);
        }
    }

    /// Appends `event` and sends it to every idle worker; a worker that fails it is dropped.
    fn broadcast(&self, event: Event) {
        let mut log = lock(&self.log);
        log.push(event);
        let mut idle = lock(&self.idle);
        let workers = std::mem::take(&mut *idle);
        for mut w in workers {
            if self.catch_up(&mut w, &log).is_ok() {
                idle.push(w);
            }
        }
    }

    /// Runs `event` on one worker; logs it when the plugin accepted it. Returns the reply.
    fn first_then_log(&self, event: Event) -> Result<Reply, String> {
        let mut log = lock(&self.log);
        let mut w = self.take(&log)?;
        match w.call(&event.request(), self.isolation.timeout) {
            Ok(reply) => {
                if matches!(reply, Reply::Done | Reply::Created(_)) {
                    log.push(event);
                    w.replayed = log.len();
                }
                lock(&self.idle).push(w);
                Ok(reply)
            }
            Err(death) => {
                self.deaths.fetch_add(1, Ordering::Relaxed);
                Err(death.to_string())
            }
        }
    }

    /// Runs a projection call on a worker. `Err` when the worker could not be had or died (counted).
    fn call(&self, request: &Request) -> Result<Reply, String> {
        let mut w = self.take(&lock(&self.log))?;
        match w.call(request, self.isolation.timeout) {
            Ok(reply) => {
                self.give_back(w);
                Ok(reply)
            }
            Err(death) => Err(self.died(&death)),
        }
    }

    fn died(&self, death: &Death) -> String {
        self.deaths.fetch_add(1, Ordering::Relaxed);
        death.to_string()
    }
}

/// A plugin library run in worker processes (`--isolate-plugins`): a [`ProjectionFactory`] whose every
/// call to the plugin crosses to a worker. See the [module](super) doc.
pub struct IsolatedFactory {
    shared: Arc<Shared>,
    initialized: bool,
}

impl std::fmt::Debug for IsolatedFactory {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("IsolatedFactory")
            .field("name", &self.shared.description.name)
            .field("path", &self.shared.path)
            .finish()
    }
}

impl IsolatedFactory {
    /// Starts a worker that loads (and validates) the library at `path` and describes it. Nothing of
    /// the library runs in this process.
    ///
    /// # Errors
    /// The loader's message from the worker, or how the worker died loading the library (a
    /// constructor that aborts, an entry point that crashes), naming the file.
    pub fn open(path: &Path, isolation: &Isolation) -> Result<Self, String> {
        let (worker, description) = Worker::spawn(&isolation.worker, path, isolation.timeout)?;
        Ok(IsolatedFactory {
            shared: Arc::new(Shared {
                path: path.to_path_buf(),
                description,
                isolation: isolation.clone(),
                log: Mutex::new(Vec::new()),
                idle: Mutex::new(vec![worker]),
                next_id: AtomicU64::new(1),
                deaths: AtomicU64::new(0),
                failed_starts: Mutex::new((0, String::new())),
            }),
            initialized: false,
        })
    }

    /// The library's file.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.shared.path
    }

    /// How many worker processes crashed, hung or broke so far (each cost the call it was serving).
    #[must_use]
    pub fn worker_deaths(&self) -> u64 {
        self.shared.deaths.load(Ordering::Relaxed)
    }

    fn plugin_error(&self, message: String) -> PluginError {
        PluginError::Invalid {
            plugin: self.shared.description.name.clone(),
            message,
        }
    }
}

impl ProjectionFactory for IsolatedFactory {
    fn name(&self) -> &str {
        &self.shared.description.name
    }

    fn summary(&self) -> &str {
        &self.shared.description.summary
    }

    fn listing_notes(&self) -> Vec<String> {
        vec!["runs isolated in a worker process (--isolate-plugins)".into()]
    }

    fn param_table(&self) -> &[ParamDecl] {
        &self.shared.description.table
    }

    fn init(&mut self, plugin_path: &str) -> Result<(), PluginError> {
        if self.initialized {
            return Ok(());
        }
        let name = self.shared.description.name.clone();
        match self.shared.first_then_log(Event::Init(plugin_path.to_string())) {
            Ok(Reply::Done) => {
                self.initialized = true;
                Ok(())
            }
            Ok(Reply::Plugin(e)) => Err(e),
            Ok(other) => Err(PluginError::Init {
                plugin: name,
                message: format!("the worker answered {other:?}"),
            }),
            Err(message) => Err(PluginError::Init {
                plugin: name,
                message: format!("{}: {message}", self.shared.path.display()),
            }),
        }
    }

    fn finalize(&mut self) {
        if std::mem::take(&mut self.initialized) {
            self.shared.broadcast(Event::Finalize);
        }
    }

    fn synchronize(&mut self, message: SyncMessage, params: Option<&ParamList>) {
        self.shared.broadcast(Event::Sync(message, params.cloned()));
    }

    fn create_projection(
        &self,
        env: &mut ProjectionEnvironment,
        params: &ParamList,
    ) -> Result<Box<dyn Projection>, PluginError> {
        let d = &self.shared.description;
        Params::resolve(&d.name, &d.table, params)?;
        let id = self.shared.next_id.fetch_add(1, Ordering::Relaxed);
        match self
            .shared
            .first_then_log(Event::Create(id, env.clone(), params.clone()))
        {
            Ok(Reply::Created(metric)) => {
                env.set_deep_metric(metric);
                Ok(Box::new(IsolatedProjection {
                    shared: Arc::clone(&self.shared),
                    id,
                }))
            }
            Ok(Reply::Plugin(e)) => Err(e),
            Ok(other) => Err(self.plugin_error(format!("the worker answered {other:?}"))),
            Err(message) => Err(self.plugin_error(format!("in create_projection: {message}"))),
        }
    }
}

impl Drop for IsolatedFactory {
    fn drop(&mut self) {
        self.finalize();
    }
}

/// A projection living in the workers.
struct IsolatedProjection {
    shared: Arc<Shared>,
    id: u64,
}

impl Projection for IsolatedProjection {
    fn property(&self, property: ProjectionProperty) -> Option<PropertyValue> {
        match self.shared.call(&Request::Property(self.id, property)) {
            Ok(Reply::Property(v)) => v,
            Ok(Reply::Unwound {
                failed: true,
                message,
            }) => resume_unwind(Box::new(UndecodableProperty {
                property: property.renderman_name(),
                reason: message,
            })),
            Ok(Reply::Unwound { message, .. }) => resume_unwind(Box::new(message)),
            Ok(other) => resume_unwind(Box::new(format!("the worker answered {other:?}"))),
            Err(why) => resume_unwind(Box::new(format!("{why} in property"))),
        }
    }

    fn project(&self, ctx: &mut ProjectionContext<'_>) {
        let mut parts = ctx.parts_mut();
        let n = parts.screen.len();
        if n == 0 {
            return;
        }
        let lost = |why: String| -> ! {
            resume_unwind(Box::new(ProjectFailed(format!(
                "{why} in project: the batch of {n} samples is lost; a new worker takes the next call"
            ))))
        };
        let taken = self.shared.take(&lock(&self.shared.log));
        let mut w = match taken {
            Ok(w) => w,
            Err(why) => lost(why),
        };
        match w.project(self.id, &mut parts, self.shared.isolation.timeout) {
            Ok(Reply::Done) => self.shared.give_back(w),
            Ok(Reply::Unwound { failed, message }) => {
                self.shared.give_back(w);
                if failed {
                    resume_unwind(Box::new(ProjectFailed(message)))
                }
                resume_unwind(Box::new(message))
            }
            Ok(other) => resume_unwind(Box::new(format!("the worker answered {other:?}"))),
            Err(death) => lost(self.shared.died(&death)),
        }
    }

    fn unproject(&self, point: Vec3, time: f32) -> Option<Point2> {
        match self.shared.call(&Request::Unproject(self.id, point, time)) {
            Ok(Reply::Point(p)) => p,
            Ok(Reply::Unwound { message, .. }) => resume_unwind(Box::new(message)),
            Ok(other) => resume_unwind(Box::new(format!("the worker answered {other:?}"))),
            Err(why) => resume_unwind(Box::new(format!("{why} in unproject"))),
        }
    }
}

impl Drop for IsolatedProjection {
    fn drop(&mut self) {
        self.shared.broadcast(Event::Destroy(self.id));
    }
}
