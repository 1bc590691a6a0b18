// `thread_seconds()`, the one clock the tracing benchmarks time passes with, and
// `fastest_trace_pass`, the pass they time; `include!`d by
// `crates/obscura-render/benches/trace.rs` and `crates/obscura-geometry/examples/trace_dump.rs`
// (bench/embree/trace_embree.cpp reads the same clock).

/// This thread's CPU time in seconds (`CLOCK_THREAD_CPUTIME_ID`): on a machine shared with other
/// jobs, time the thread spends descheduled does not count.
#[cfg(target_os = "linux")]
fn thread_seconds() -> f64 {
    #[repr(C)]
    struct Timespec {
        sec: i64,
        nsec: i64,
    }
    unsafe extern "C" {
        fn clock_gettime(clock: i32, out: *mut Timespec) -> i32;
    }
    let mut ts = Timespec { sec: 0, nsec: 0 };
    // SAFETY: CLOCK_THREAD_CPUTIME_ID is 3 on Linux; `ts` is a valid out-pointer.
    unsafe { clock_gettime(3, &mut ts) };
    ts.sec as f64 + ts.nsec as f64 * 1e-9
}

/// Wall-clock seconds since the first call (off Linux, where the thread clock is not wired up).
#[cfg(not(target_os = "linux"))]
fn thread_seconds() -> f64 {
    static START: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();
    START.get_or_init(std::time::Instant::now).elapsed().as_secs_f64()
}

/// The fastest of `passes` passes over `rays` in [`thread_seconds`]: each pass traces every ray
/// through `bvh` (`occluded` when `shadow`, else `intersect`) and counts the hits.
fn fastest_trace_pass(
    bvh: &obscura_geometry::bvh::MeshBvh,
    rays: &[obscura_geometry::ray::Ray],
    shadow: bool,
    passes: usize,
) -> f64 {
    (0..passes)
        .map(|_| {
            let start = thread_seconds();
            let n = if shadow {
                rays.iter().filter(|r| bvh.occluded(r)).count()
            } else {
                rays.iter().filter(|r| bvh.intersect(r).is_some()).count()
            };
            std::hint::black_box(n);
            thread_seconds() - start
        })
        .fold(f64::INFINITY, f64::min)
}
