//! Every committed input of the fuzzer — the seed corpus and every input that ever panicked or hung
//! (`regressions/`) — runs through its target without a panic and in time; and a short fuzz run of
//! every target finds no panic (the smoke run; the long runs are `obscura-fuzz all --inputs N`).

use std::time::{Duration, Instant};

use obscura_fuzz::{Outcome, TARGETS, Target, corpus_root, fuzz, inputs, regressions_root, run_one};

/// A corpus input must finish well inside the 30-s hang limit even in a debug build.
const LIMIT: Duration = Duration::from_secs(10);

fn replay(root: &std::path::Path) -> Vec<(Target, String, Outcome)> {
    let scratch = tempfile::tempdir().unwrap();
    let mut out = Vec::new();
    for target in TARGETS {
        for (path, bytes) in inputs(root, target) {
            let t = Instant::now();
            let outcome = run_one(target, &bytes, scratch.path());
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            assert!(
                t.elapsed() < LIMIT,
                "{} {name} took {:?}",
                target.name(),
                t.elapsed()
            );
            assert!(
                !matches!(outcome, Outcome::Panicked(_)),
                "{} {name}: {outcome:?}",
                target.name()
            );
            out.push((target, name, outcome));
        }
    }
    out
}

#[test]
fn every_seed_input_runs_and_the_well_formed_ones_are_accepted() {
    let outcomes = replay(&corpus_root());
    for target in TARGETS {
        assert!(
            outcomes.iter().any(|(t, _, _)| *t == target),
            "{}: no seed input",
            target.name()
        );
    }
    // Seeds reach deep: all but the deliberately malformed ones parse and build a camera.
    let refused: Vec<String> = outcomes
        .iter()
        .filter(|(target, name, outcome)| {
            !(name.starts_with("malformed") || *target == Target::Abi) && *outcome != Outcome::Accepted
        })
        .map(|(target, name, outcome)| format!("{} {name}: {outcome:?}", target.name()))
        .collect();
    assert!(refused.is_empty(), "{refused:#?}");
}

#[test]
fn every_input_the_fuzzer_ever_found_stays_fixed() {
    replay(&regressions_root());
}

#[test]
fn a_short_fuzz_run_of_every_target_finds_no_panic() {
    let scratch = tempfile::tempdir().unwrap();
    let save = tempfile::tempdir().unwrap();
    for target in TARGETS {
        let stats = fuzz(target, 150, 20261125, scratch.path(), save.path(), &|_| {});
        assert_eq!(stats.inputs, 150);
        assert!(stats.panics.is_empty(), "{}: {:?}", target.name(), stats.panics);
    }
}
