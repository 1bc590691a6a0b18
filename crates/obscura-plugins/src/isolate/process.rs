//! The host's side of one worker process: starting it, calling it with a deadline, and telling how
//! it died.

use std::io::Write;
use std::os::fd::{AsFd, AsRawFd, BorrowedFd};
use std::os::unix::net::UnixStream;
use std::os::unix::process::{CommandExt, ExitStatusExt};
use std::path::Path;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use obscura_sdk::ContextParts;

use super::shm::Shm;
use super::wire::{self, Description, Reply, Request};
use super::{SHM_FD_VAR, WorkerCommand};

/// Rays the shared memory holds when a worker starts (grown on demand).
const INITIAL_RAYS: usize = 4096;

/// How long a worker whose socket was closed gets to exit before it is killed.
const GRACE: Duration = Duration::from_secs(2);

/// Why a call to a worker has no answer.
#[derive(Debug, Clone, PartialEq)]
pub enum Death {
    /// The process ended (how, in words).
    Ended(String),
    /// The call did not return in time; the process was killed.
    Hung(Duration),
    /// The exchange itself failed (a malformed reply, the memory could not grow); the process was
    /// killed.
    Broken(String),
}

impl std::fmt::Display for Death {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Death::Ended(how) => write!(f, "the plugin's worker process {how}"),
            Death::Hung(t) => write!(
                f,
                "the plugin did not return within {:.3} s (--plugin-timeout); its worker process was killed",
                t.as_secs_f64()
            ),
            Death::Broken(why) => write!(f, "the plugin's worker process failed ({why}) and was killed"),
        }
    }
}

/// A running worker.
pub struct Worker {
    child: Child,
    socket: UnixStream,
    shm: Shm,
    /// The socket's read timeout as last set (setting it is a system call).
    read_timeout: Option<Duration>,
    /// How many events of the factory's log this worker has replayed.
    pub replayed: usize,
}

impl Worker {
    /// Starts a worker and has it load and describe the library at `library`.
    ///
    /// # Errors
    /// Why the worker could not start, or the loader's message when the library did not load (or the
    /// process died loading it).
    pub fn spawn(
        command: &WorkerCommand,
        library: &Path,
        timeout: Duration,
    ) -> Result<(Worker, Description), String> {
        let shm = Shm::create(INITIAL_RAYS * super::shm::BYTES_PER_RAY)
            .map_err(|e| format!("cannot create the shared memory for a plugin worker: {e}"))?;
        let (ours, theirs) =
            UnixStream::pair().map_err(|e| format!("cannot create a socket for a plugin worker: {e}"))?;
        let stdout = std::io::stderr()
            .as_fd()
            .try_clone_to_owned()
            .map_err(|e| format!("cannot start a plugin worker: {e}"))?;
        let fd = shm.file().as_raw_fd();
        let mut cmd = Command::new(&command.program);
        cmd.args(&command.args)
            .env(SHM_FD_VAR, fd.to_string())
            .stdin(Stdio::from(std::os::fd::OwnedFd::from(theirs)))
            // What the plugin prints goes to our stderr: our stdout may be a data stream.
            .stdout(Stdio::from(stdout))
            .stderr(Stdio::inherit());
        // SAFETY: runs in the child between fork and exec, where only async-signal-safe calls are
        // allowed: `fcntl(F_SETFD)` is one. `fd` stays open in the parent until `spawn` returns.
        unsafe {
            cmd.pre_exec(move || {
                rustix::io::fcntl_setfd(BorrowedFd::borrow_raw(fd), rustix::io::FdFlags::empty())?;
                Ok(())
            });
        }
        let child = cmd.spawn().map_err(|e| {
            format!(
                "cannot start the plugin worker `{}`: {e}",
                command.program.display()
            )
        })?;
        // Our copy of the worker's end must close, or its death would never reach us as end of file.
        drop(cmd);
        let mut worker = Worker {
            child,
            socket: ours,
            shm,
            read_timeout: None,
            replayed: 0,
        };
        let library = library.to_string_lossy().into_owned();
        match worker.call(&Request::Load(library), timeout) {
            Ok(Reply::Described(d)) => Ok((worker, d)),
            Ok(Reply::LoadFailed(e)) => Err(e),
            Ok(other) => Err(format!(
                "the plugin worker answered {other:?} to loading the library"
            )),
            Err(death) => Err(format!("{death} while loading the library")),
        }
    }

    /// Sends `request` and waits up to `timeout` for the reply.
    ///
    /// # Errors
    /// How the worker died; it is reaped (and killed first when it hung).
    pub fn call(&mut self, request: &Request, timeout: Duration) -> Result<Reply, Death> {
        let sent = {
            let mut w = NoSignal(&self.socket);
            wire::send(&mut w, &request.encode())
        };
        if sent.is_err() {
            return Err(Death::Ended(self.reap()));
        }
        let timeout = timeout.max(Duration::from_millis(1));
        if self.read_timeout != Some(timeout) {
            if let Err(e) = self.socket.set_read_timeout(Some(timeout)) {
                self.kill();
                return Err(Death::Broken(e.to_string()));
            }
            self.read_timeout = Some(timeout);
        }
        match wire::receive(&mut self.socket) {
            Ok(body) => Reply::decode(&body).map_err(|e| {
                self.kill();
                Death::Broken(format!("a malformed reply: {e}"))
            }),
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                self.kill();
                Err(Death::Hung(timeout))
            }
            Err(_) => Err(Death::Ended(self.reap())),
        }
    }

    /// Calls `project` on projection `id` with the batch in `parts`: copies the batch into the shared
    /// memory, and on success copies time, rays and tint back.
    ///
    /// # Errors
    /// As [`Worker::call`].
    pub fn project(
        &mut self,
        id: u64,
        parts: &mut ContextParts<'_>,
        timeout: Duration,
    ) -> Result<Reply, Death> {
        let n = parts.screen.len();
        if let Err(e) = self.shm.reserve(n) {
            self.kill();
            return Err(Death::Broken(format!(
                "cannot grow the shared memory to {n} rays: {e}"
            )));
        }
        {
            let a = self.shm.arrays(n).expect("reserved above");
            a.screen.copy_from_slice(parts.screen);
            a.lens.copy_from_slice(parts.lens);
            a.aperture.copy_from_slice(parts.aperture);
            a.time.copy_from_slice(parts.time);
            a.rays.copy_from_slice(parts.rays);
            a.tint.copy_from_slice(parts.tint);
        }
        let len = self.shm.len() as u64;
        let reply = self.call(&Request::Project { id, n: n as u64, len }, timeout)?;
        if reply == Reply::Done {
            let a = self.shm.arrays(n).expect("reserved above");
            parts.time.copy_from_slice(a.time);
            parts.rays.copy_from_slice(a.rays);
            parts.tint.copy_from_slice(a.tint);
        }
        Ok(reply)
    }

    fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    /// Waits for a worker whose socket closed, killing it if it does not exit in time; says how it
    /// ended.
    fn reap(&mut self) -> String {
        let start = Instant::now();
        loop {
            match self.child.try_wait() {
                Ok(Some(status)) => return describe(status),
                Ok(None) if start.elapsed() < GRACE => std::thread::sleep(Duration::from_millis(2)),
                _ => {
                    self.kill();
                    return "closed its socket without exiting, and was killed".into();
                }
            }
        }
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        // Closing the socket tells the worker to finish (its factory is dropped, so a plugin not yet
        // finalised is); a worker that does not exit in time is killed.
        let _ = self.socket.shutdown(std::net::Shutdown::Both);
        if matches!(self.child.try_wait(), Ok(None)) {
            self.reap();
        }
    }
}

/// How a process ended, in words: `was killed by signal 11 (SIGSEGV: segmentation fault)`.
fn describe(status: ExitStatus) -> String {
    if let Some(sig) = status.signal() {
        let name = match sig {
            4 => " (SIGILL: illegal instruction)",
            6 => " (SIGABRT: abort)",
            7 => " (SIGBUS: bus error)",
            8 => " (SIGFPE: arithmetic exception)",
            9 => " (SIGKILL)",
            11 => " (SIGSEGV: segmentation fault)",
            13 => " (SIGPIPE)",
            15 => " (SIGTERM)",
            _ => "",
        };
        return format!("was killed by signal {sig}{name}");
    }
    match status.code() {
        Some(c) => format!("exited with status {c}"),
        None => format!("ended ({status})"),
    }
}

/// Writes to the socket with `MSG_NOSIGNAL`: a dead worker is an error to report, never a `SIGPIPE`
/// to the host.
struct NoSignal<'a>(&'a UnixStream);

impl Write for NoSignal<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        rustix::net::send(self.0, buf, rustix::net::SendFlags::NOSIGNAL).map_err(std::io::Error::from)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}
