//! `obscura-fuzz`: runs the fuzz targets and reports counts; exit 1 when any input panicked.

use std::io::Write;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use obscura_fuzz::{TARGETS, Target, fuzz, regressions_root};

const USAGE: &str = "usage: obscura-fuzz TARGET|all [--inputs N] [--seed S] [--save DIR] [--hang SECONDS]
  TARGET: rib rib-bytes gltf obj colmap opencv kalibr ocamcalib param abi
  --inputs N     inputs per target (default 100000)
  --seed S       the run's seed (default 1)
  --save DIR     where panicking and hanging inputs are written (default: the crate's regressions/)
  --hang SECONDS an input running longer is a hang: it is saved and the process exits with 2 (default 30)";

struct Options {
    targets: Vec<Target>,
    inputs: u64,
    seed: u64,
    save: PathBuf,
    hang: Duration,
}

fn options() -> Result<Options, String> {
    let mut args = std::env::args().skip(1);
    let which = args.next().ok_or("no target given")?;
    let targets = if which == "all" {
        TARGETS.to_vec()
    } else {
        vec![Target::from_name(&which).ok_or_else(|| format!("unknown target \"{which}\""))?]
    };
    let mut o = Options {
        targets,
        inputs: 100_000,
        seed: 1,
        save: regressions_root(),
        hang: Duration::from_secs(30),
    };
    while let Some(flag) = args.next() {
        let value = args.next().ok_or_else(|| format!("{flag} needs a value"))?;
        let number = || {
            value
                .parse::<u64>()
                .map_err(|_| format!("{flag} {value}: expected a whole number"))
        };
        match flag.as_str() {
            "--inputs" => o.inputs = number()?,
            "--seed" => o.seed = number()?,
            "--hang" => o.hang = Duration::from_secs(number()?),
            "--save" => o.save = PathBuf::from(value),
            _ => return Err(format!("unknown option {flag}")),
        }
    }
    Ok(o)
}

/// Inputs per second of the mutator alone on the RIB seeds (the runner's own cost, for comparison).
fn mutator_rate() -> f64 {
    let seeds: Vec<Vec<u8>> = obscura_fuzz::inputs(&obscura_fuzz::corpus_root(), Target::Rib)
        .into_iter()
        .map(|(_, b)| b)
        .collect();
    let Some(first) = seeds.first() else {
        return 0.0;
    };
    let mut rng = obscura_fuzz::mutate::Rng::new(1);
    let start = Instant::now();
    let mut bytes = 0usize;
    const N: usize = 100_000;
    for k in 0..N {
        let base = &seeds[k % seeds.len()];
        bytes += obscura_fuzz::mutate::mutate(
            &mut rng,
            base,
            first,
            Target::Rib.dictionary(),
            obscura_fuzz::MAX_LEN,
        )
        .len();
    }
    std::hint::black_box(bytes);
    N as f64 / start.elapsed().as_secs_f64()
}

fn main() {
    let o = match options() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}\n{USAGE}");
            std::process::exit(2);
        }
    };
    // Parsers that panic are the finding, not noise on stderr: the message is reported once below.
    std::panic::set_hook(Box::new(|_| {}));
    // Files of the glTF and OBJ targets: in memory where there is a tmpfs, a disk costs 100x.
    let shm = std::path::Path::new("/dev/shm");
    let base = if shm.is_dir() {
        shm.to_path_buf()
    } else {
        std::env::temp_dir()
    };
    let scratch = base.join(format!("obscura-fuzz-{}", std::process::id()));
    if let Err(e) = std::fs::create_dir_all(&scratch) {
        eprintln!("error: cannot create {}: {e}", scratch.display());
        std::process::exit(2);
    }
    // The watchdog: the input in flight and when it started.
    let current: Arc<Mutex<(Target, Vec<u8>, Instant)>> =
        Arc::new(Mutex::new((o.targets[0], Vec::new(), Instant::now())));
    {
        let (current, save, hang) = (Arc::clone(&current), o.save.clone(), o.hang);
        std::thread::spawn(move || {
            loop {
                std::thread::sleep(Duration::from_millis(500));
                let guard = current.lock().unwrap_or_else(|e| e.into_inner());
                if guard.2.elapsed() > hang {
                    let dir = save.join(guard.0.name());
                    let path = dir.join(format!("hang-{:016x}", obscura_fuzz::hash(&guard.1)));
                    let _ = std::fs::create_dir_all(&dir);
                    let _ = std::fs::write(&path, &guard.1);
                    eprintln!(
                        "HANG: {} input ran over {:?}; saved as {}",
                        guard.0.name(),
                        hang,
                        path.display()
                    );
                    std::process::exit(2);
                }
            }
        });
    }
    let mut panics = 0;
    let mut total = 0;
    println!("target     inputs  accepted  messages  panics  slow(>1s)  slowest(ms)  inputs/s");
    for &target in &o.targets {
        let record = |input: &[u8]| {
            let mut g = current.lock().unwrap_or_else(|e| e.into_inner());
            *g = (target, input.to_vec(), Instant::now());
        };
        let s = fuzz(target, o.inputs, o.seed, &scratch, &o.save, &record);
        total += s.inputs;
        panics += s.panics.len();
        println!(
            "{:<9} {:>8} {:>9} {:>9} {:>7} {:>10} {:>12.1} {:>9.0}",
            target.name(),
            s.inputs,
            s.accepted,
            s.messages,
            s.panics.len(),
            s.slow,
            s.slowest.as_secs_f64() * 1e3,
            s.inputs as f64 / s.seconds.max(1e-9)
        );
        for (path, message) in &s.panics {
            println!("  PANIC {}: {message}", path.display());
        }
        let _ = std::io::stdout().flush();
    }
    let _ = std::fs::remove_dir_all(&scratch);
    println!("total {total} inputs, {panics} panics");
    println!(
        "reference: the mutator alone makes {:.0} inputs/s",
        mutator_rate()
    );
    if panics > 0 {
        std::process::exit(1);
    }
}
