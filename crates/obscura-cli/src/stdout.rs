//! Standard output that ends quietly on a closed pipe (`obscura check … | head -1`).
//!
//! `println!` panics when the reader has gone; [`write`] ends the process with status 0 instead, as
//! the output nobody reads is no failure of ours.

use std::io::Write;

/// Writes `args` to standard output. A broken pipe ends the process quietly (status 0); another
/// error is reported on stderr and ends it with status 1.
pub fn write(args: std::fmt::Arguments<'_>) {
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_fmt(args).and_then(|()| out.flush()) {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        eprintln!("error: cannot write to standard output: {e}");
        std::process::exit(1);
    }
}

/// `print!` through [`write`].
macro_rules! out {
    ($($t:tt)*) => { $crate::stdout::write(format_args!($($t)*)) };
}

/// `println!` through [`write`].
macro_rules! outln {
    ($($t:tt)*) => { $crate::stdout::write(format_args!("{}\n", format_args!($($t)*))) };
}

pub(crate) use {out, outln};
