//! A plugin worker on its own: what [`obscura_plugins::isolate::WorkerCommand`] names for hosts other
//! than the `obscura` binary (which is its own worker), and for this crate's tests and benchmarks.

#![forbid(unsafe_code)]

fn main() {
    std::process::exit(obscura_plugins::isolate::worker_main());
}
