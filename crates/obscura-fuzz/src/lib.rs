//! # obscura-fuzz
//!
//! A structured mutation fuzzer for every parser a user's input reaches: RIB (ASCII, and a file's
//! bytes as the CLI reads them: binary, gzip, Latin-1), glTF, OBJ, the four calibration formats,
//! `--param` arguments and the plugin ABI's table rows and property answers. cargo-fuzz needs a
//! nightly compiler, so the fuzzer is ordinary Rust that runs on stable:
//!
//! - **inputs**: the committed seed corpus (`corpus/<target>/`), mutated by [`mutate::mutate`]
//!   (byte edits, the target's tokens, numbers at the edges of `f32`/`u32`, splices, repeated lines;
//!   for binary RIB, encoded tokens and floats at the edges of `f32`);
//! - **feedback**: without coverage instrumentation, the outcome is the signal: an input that is
//!   accepted, or refused with a message not seen before, joins the pool that later inputs are
//!   mutated from, so the fuzzer walks past the first error of each kind;
//! - **oracle**: a panic (caught and counted), an input slower than [`SLOW`] (counted), and — in the
//!   runner — an input that runs longer than the watchdog's limit or a process that aborts;
//! - **regressions**: every input that ever panicked or hung is kept under `regressions/<target>/`
//!   and replayed by `cargo test` (`tests/corpus.rs`) with the corpus.
//!
//! `cargo run --release -p obscura-fuzz -- all --inputs 1000000` runs every target; see `--help`.

#![deny(unsafe_op_in_unsafe_fn)]

pub mod mutate;
pub mod targets;

#[allow(missing_docs, dead_code, clippy::all)]
#[path = "../../obscura-cli/src/params.rs"]
mod params;

use std::collections::HashSet;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

pub use targets::{TARGETS, Target};

use crate::mutate::{Rng, mutate_as};

/// An input slower than this is counted as slow (a hang is far longer: see the runner's watchdog).
pub const SLOW: Duration = Duration::from_secs(1);

/// The longest input the mutator makes, in bytes.
pub const MAX_LEN: usize = 64 * 1024;

/// The most inputs kept in the pool of one target.
const POOL: usize = 4096;

/// What happened to one input.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Outcome {
    /// Accepted.
    Accepted,
    /// Refused with this message.
    Refused(String),
    /// The parser panicked with this message.
    Panicked(String),
}

/// Runs `target` on `input`, catching a panic.
pub fn run_one(target: Target, input: &[u8], scratch: &Path) -> Outcome {
    match catch_unwind(AssertUnwindSafe(|| target.run(input, scratch))) {
        Ok(Ok(())) => Outcome::Accepted,
        Ok(Err(message)) => Outcome::Refused(message),
        Err(payload) => Outcome::Panicked(
            payload
                .downcast_ref::<&str>()
                .map(|s| (*s).to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "a panic without a message".into()),
        ),
    }
}

/// The committed corpus directory of the crate.
#[must_use]
pub fn corpus_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("corpus")
}

/// The committed regression directory of the crate.
#[must_use]
pub fn regressions_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("regressions")
}

/// The files of `root/<target>/`, sorted by name (none when the directory is missing).
#[must_use]
pub fn inputs(root: &Path, target: Target) -> Vec<(PathBuf, Vec<u8>)> {
    let Ok(entries) = std::fs::read_dir(root.join(target.name())) else {
        return Vec::new();
    };
    let mut files: Vec<PathBuf> = entries
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files
        .into_iter()
        .filter_map(|p| std::fs::read(&p).ok().map(|b| (p, b)))
        .collect()
}

/// Counts of one target's run.
#[derive(Debug, Clone, Default)]
pub struct Stats {
    /// Inputs run.
    pub inputs: u64,
    /// Inputs accepted.
    pub accepted: u64,
    /// Distinct refusal messages (their first line, numbers blanked).
    pub messages: usize,
    /// Inputs that panicked, with the saved file of each.
    pub panics: Vec<(PathBuf, String)>,
    /// Inputs slower than [`SLOW`].
    pub slow: u64,
    /// The slowest input's time.
    pub slowest: Duration,
    /// Wall time.
    pub seconds: f64,
}

/// A refusal message with digits blanked, so that one kind of error counts once.
fn message_kind(message: &str) -> String {
    message
        .lines()
        .next()
        .unwrap_or_default()
        .chars()
        .map(|c| if c.is_ascii_digit() { '#' } else { c })
        .take(120)
        .collect()
}

/// A short hash of `bytes` for file names (FNV-1a).
#[must_use]
pub fn hash(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// Fuzzes `target` with `count` mutated inputs from its corpus, seeded by `seed`. Panicking inputs
/// are written to `save/<target>/panic-<hash>`; `current` is told each input before it runs (the
/// watchdog saves it if it never returns).
pub fn fuzz(
    target: Target,
    count: u64,
    seed: u64,
    scratch: &Path,
    save: &Path,
    current: &dyn Fn(&[u8]),
) -> Stats {
    let start = Instant::now();
    let mut pool: Vec<Vec<u8>> = inputs(&corpus_root(), target)
        .into_iter()
        .map(|(_, b)| b)
        .collect();
    pool.extend(inputs(&regressions_root(), target).into_iter().map(|(_, b)| b));
    if pool.is_empty() {
        pool.push(Vec::new());
    }
    let seeds = pool.len();
    let mut seen: HashSet<String> = HashSet::new();
    let mut rng = Rng::new(seed ^ hash(target.name().as_bytes()));
    let mut stats = Stats::default();
    for _ in 0..count {
        let base = &pool[rng.below(pool.len())];
        let other = &pool[rng.below(pool.len())];
        let input = mutate_as(
            &mut rng,
            base,
            other,
            target.dictionary(),
            target.binary(),
            MAX_LEN,
        );
        current(&input);
        let t = Instant::now();
        let outcome = run_one(target, &input, scratch);
        let elapsed = t.elapsed();
        stats.inputs += 1;
        stats.slowest = stats.slowest.max(elapsed);
        if elapsed > SLOW {
            stats.slow += 1;
        }
        let novel = match &outcome {
            Outcome::Accepted => {
                stats.accepted += 1;
                rng.below(16) == 0
            }
            Outcome::Refused(m) => seen.insert(message_kind(m)),
            Outcome::Panicked(m) => {
                let dir = save.join(target.name());
                let path = dir.join(format!("panic-{:016x}", hash(&input)));
                if std::fs::create_dir_all(&dir).is_ok() {
                    let _ = std::fs::write(&path, &input);
                }
                stats.panics.push((path, m.clone()));
                false
            }
        };
        if novel {
            if pool.len() < POOL {
                pool.push(input);
            } else {
                // Keep the seeds; replace a grown input.
                let k = seeds + rng.below(pool.len() - seeds);
                pool[k] = input;
            }
        }
    }
    stats.messages = seen.len();
    stats.seconds = start.elapsed().as_secs_f64();
    stats
}
