//! The worker process's side: load the library with the ordinary in-process loader, then answer the
//! host's requests one at a time until the host closes the socket.
//!
//! The worker calls the plugin through the very [`PluginFactory`] adapter an in-process host uses, so
//! an isolated plugin is called in exactly the same way; only what crosses the socket is new.

use std::collections::HashMap;
use std::fs::File;
use std::os::fd::{AsFd, FromRawFd};
use std::os::unix::net::UnixStream;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use obscura_host::contract::{ProjectFailed, UndecodableProperty, panic_message};
use obscura_sdk::{Projection, ProjectionContext, ProjectionFactory};

use super::SHM_FD_VAR;
use super::shm::Shm;
use super::wire::{self, Description, Reply, Request};
use crate::library::PluginFactory;

/// What one worker holds.
#[derive(Default)]
struct State {
    factory: Option<PluginFactory>,
    projections: HashMap<u64, Box<dyn Projection>>,
    shm: Option<Shm>,
}

/// Serves the host on standard input (a Unix socket) with the shared memory whose descriptor
/// [`SHM_FD_VAR`] names. Returns the exit code: 0 when the host closed the socket, 2 when the worker
/// was not started by a host.
pub fn serve() -> i32 {
    let Some(fd) = std::env::var(SHM_FD_VAR).ok().and_then(|v| v.parse::<i32>().ok()) else {
        eprintln!("this is Obscura's plugin worker; hosts start it (see --isolate-plugins)");
        return 2;
    };
    let Ok(stdin) = std::io::stdin().as_fd().try_clone_to_owned() else {
        return 2;
    };
    let mut socket = UnixStream::from(stdin);
    watch_host();
    // SAFETY: the host passed this descriptor, open and ours alone, under this variable (it clears
    // close-on-exec on exactly that descriptor before starting us).
    let file = unsafe { File::from_raw_fd(fd) };
    let mut state = State {
        shm: Shm::map(file).ok(),
        ..State::default()
    };
    loop {
        let Ok(body) = wire::receive(&mut socket) else {
            return 0;
        };
        let reply = match Request::decode(&body) {
            Ok(request) => state.handle(request),
            Err(e) => Reply::Unwound {
                failed: false,
                message: format!("the worker could not read the host's request: {e}"),
            },
        };
        if wire::send(&mut socket, &reply.encode()).is_err() {
            return 0;
        }
    }
}

/// How often a worker looks whether its host is still there.
const HOST_CHECK: std::time::Duration = std::time::Duration::from_millis(100);

/// Ends this worker soon after its host dies, even while the plugin is stuck in a call (which the
/// closed socket cannot interrupt): a thread watches the parent process and exits when it changes
/// (the worker was handed to init or a subreaper). Without it, a plugin in an infinite loop would
/// outlive a host killed with SIGKILL.
fn watch_host() {
    let host = std::os::unix::process::parent_id();
    let watcher = std::thread::Builder::new()
        .name("host-watch".into())
        .spawn(move || {
            loop {
                std::thread::sleep(HOST_CHECK);
                if std::os::unix::process::parent_id() != host {
                    std::process::exit(0);
                }
            }
        });
    // Without the thread the worker still ends when the socket closes; only a stuck call outlives.
    drop(watcher);
}

fn unwound(message: String) -> Reply {
    Reply::Unwound {
        failed: false,
        message,
    }
}

impl State {
    fn handle(&mut self, request: Request) -> Reply {
        if let Request::Load(path) = &request {
            return match PluginFactory::open(Path::new(path)) {
                Ok(f) => {
                    let d = Description {
                        name: f.name().to_string(),
                        summary: f.summary().to_string(),
                        table: f.param_table().to_vec(),
                    };
                    self.factory = Some(f);
                    Reply::Described(d)
                }
                Err(e) => Reply::LoadFailed(e.to_string()),
            };
        }
        let Some(factory) = self.factory.as_mut() else {
            return unwound("the worker has loaded no library".into());
        };
        match request {
            Request::Load(_) => unreachable!("handled above"),
            Request::Init(path) => match factory.init(&path) {
                Ok(()) => Reply::Done,
                Err(e) => Reply::Plugin(e),
            },
            Request::Sync(message, list) => {
                factory.synchronize(message, list.as_ref());
                Reply::Done
            }
            Request::Create(id, mut env, list) => match factory.create_projection(&mut env, &list) {
                Ok(p) => {
                    self.projections.insert(id, p);
                    Reply::Created(env.deep_metric())
                }
                Err(e) => Reply::Plugin(e),
            },
            Request::Destroy(id) => {
                self.projections.remove(&id);
                Reply::Done
            }
            Request::Finalize => {
                factory.finalize();
                Reply::Done
            }
            Request::Property(id, property) => self.on(id, |p| {
                match catch_unwind(AssertUnwindSafe(|| p.property(property))) {
                    Ok(v) => Reply::Property(v),
                    Err(payload) => match payload.downcast_ref::<UndecodableProperty>() {
                        Some(u) => Reply::Unwound {
                            failed: true,
                            message: u.reason.clone(),
                        },
                        None => unwound(panic_message(payload.as_ref())),
                    },
                }
            }),
            Request::Unproject(id, point, time) => self.on(id, |p| {
                match catch_unwind(AssertUnwindSafe(|| p.unproject(point, time))) {
                    Ok(v) => Reply::Point(v),
                    Err(payload) => unwound(panic_message(payload.as_ref())),
                }
            }),
            Request::Project { id, n, len } => self.project(id, n, len),
        }
    }

    fn on(&self, id: u64, f: impl FnOnce(&dyn Projection) -> Reply) -> Reply {
        match self.projections.get(&id) {
            Some(p) => f(p.as_ref()),
            None => unwound(format!("the worker has no projection {id}")),
        }
    }

    fn project(&mut self, id: u64, n: u64, len: u64) -> Reply {
        let Some(p) = self.projections.get(&id) else {
            return unwound(format!("the worker has no projection {id}"));
        };
        let Some(shm) = self.shm.as_mut() else {
            return unwound("the worker has no shared memory".into());
        };
        if let Err(e) = shm.remap(len as usize) {
            return unwound(format!("the worker could not map the shared memory: {e}"));
        }
        let Some(a) = shm.arrays(n as usize) else {
            return unwound(format!("{n} rays do not fit the shared memory of {len} bytes"));
        };
        let mut ctx = ProjectionContext::new(a.screen, a.lens, a.aperture, a.time, a.rays, a.tint)
            .expect("the layout gives every array n elements");
        match catch_unwind(AssertUnwindSafe(|| p.project(&mut ctx))) {
            Ok(()) => Reply::Done,
            Err(payload) => match payload.downcast_ref::<ProjectFailed>() {
                Some(f) => Reply::Unwound {
                    failed: true,
                    message: f.0.clone(),
                },
                None => unwound(panic_message(payload.as_ref())),
            },
        }
    }
}
