//! Frame sequences: which frames to render (`--frames 12`, `--frames 1-24`, `--frames 1-10,20`) and
//! the file each frame writes.
//!
//! Shared by every source of frames: RIB's `FrameBegin n` blocks and animated glTF.
//!
//! ## The output path of frame `n`
//!
//! 1. A run of `#` in the file name becomes `n`, zero-padded to the run's length (`beauty.####.exr`
//!    → `beauty.0012.exr`; `f#.png` → `f12.png`: the run is a minimum width, never a truncation).
//!    A printf-style `%d` or `%0Nd` is read the same way (`beauty.%04d.exr`), as Nuke and ffmpeg do.
//!    This applies whether one frame or several are rendered.
//! 2. Otherwise, when several frames are rendered, `.NNNN` (four digits at least) is put before the
//!    extension: `out.exr` → `out.0012.exr`, `out` → `out.0012`. With one frame the path is used as
//!    given.
//!
//! Only the file name is rewritten; a `#` in a directory name is kept.

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use obscura_scene::Display;

/// The digits a frame number gets before the extension when the path has no `#` run.
const DEFAULT_PADDING: usize = 4;

/// A selection of frames: one number, an inclusive range `A-B`, or a comma-separated list of them
/// (`1-10,20,30-32`). Kept sorted, with overlapping and adjacent ranges merged.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct FrameSpec {
    /// Disjoint inclusive ranges in increasing order, none adjacent to the next.
    ranges: Vec<(u32, u32)>,
}

/// Why a frame selection could not be read: the text as given and what was expected.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("'{text}': {reason}; expected a frame N, a range A-B, or a comma-separated list of them, e.g. 1-24")]
pub struct FrameSpecError {
    /// The selection as written.
    pub text: String,
    /// What is wrong with it.
    pub reason: String,
}

impl FrameSpec {
    /// Frame `n` alone.
    #[must_use]
    pub fn single(n: u32) -> Self {
        FrameSpec { ranges: vec![(n, n)] }
    }

    /// Frames `first..=last`.
    ///
    /// # Errors
    /// When `last < first`.
    pub fn range(first: u32, last: u32) -> Result<Self, FrameSpecError> {
        if last < first {
            return Err(FrameSpecError {
                text: format!("{first}-{last}"),
                reason: format!("the range ends ({last}) before it starts ({first})"),
            });
        }
        Ok(FrameSpec {
            ranges: vec![(first, last)],
        })
    }

    /// Reads `N`, `A-B` or a comma-separated list of them; spaces around numbers, dashes and commas
    /// are allowed.
    ///
    /// # Errors
    /// A message quoting `text` and saying what is wrong: an empty item, a number that is not a
    /// non-negative integer, or a range that ends before it starts.
    pub fn parse(text: &str) -> Result<Self, FrameSpecError> {
        let fail = |reason: String| FrameSpecError {
            text: text.to_string(),
            reason,
        };
        let number = |s: &str| {
            let s = s.trim();
            if s.is_empty() {
                return Err(fail("a frame number is missing".into()));
            }
            s.parse::<u32>()
                .map_err(|_| fail(format!("'{s}' is not a frame number (a non-negative integer)")))
        };
        let mut ranges = Vec::new();
        for item in text.split(',') {
            if item.trim().is_empty() {
                return Err(fail("an empty item".into()));
            }
            let (first, last) = match item.split_once('-') {
                Some((a, b)) => (number(a)?, number(b)?),
                None => {
                    let n = number(item)?;
                    (n, n)
                }
            };
            if last < first {
                return Err(fail(format!("the range {first}-{last} ends before it starts")));
            }
            ranges.push((first, last));
        }
        Ok(Self::normalized(ranges))
    }

    /// Sorts and merges overlapping or adjacent ranges.
    fn normalized(mut ranges: Vec<(u32, u32)>) -> Self {
        ranges.sort_unstable();
        let mut merged: Vec<(u32, u32)> = Vec::with_capacity(ranges.len());
        for (a, b) in ranges {
            match merged.last_mut() {
                Some(last) if u64::from(a) <= u64::from(last.1) + 1 => last.1 = last.1.max(b),
                _ => merged.push((a, b)),
            }
        }
        FrameSpec { ranges: merged }
    }

    /// True when frame `n` is selected.
    #[must_use]
    pub fn contains(&self, n: u32) -> bool {
        self.ranges.iter().any(|&(a, b)| (a..=b).contains(&n))
    }

    /// The first frame selected.
    #[must_use]
    pub fn first(&self) -> u32 {
        self.ranges[0].0
    }

    /// The last frame selected.
    #[must_use]
    pub fn last(&self) -> u32 {
        self.ranges[self.ranges.len() - 1].1
    }

    /// How many frames are selected.
    #[must_use]
    pub fn len(&self) -> u64 {
        self.ranges
            .iter()
            .map(|&(a, b)| u64::from(b) - u64::from(a) + 1)
            .sum()
    }

    /// Never true: a selection holds at least one frame (kept for the `len`/`is_empty` pair).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.ranges.is_empty()
    }

    /// The selected frames in increasing order.
    pub fn frames(&self) -> impl Iterator<Item = u32> + '_ {
        self.ranges.iter().flat_map(|&(a, b)| a..=b)
    }

    /// The frames of `available` (the frame numbers a file holds, in file order) that are selected,
    /// in file order.
    ///
    /// # Errors
    /// When none is: a message naming the selection and the frames the file has.
    pub fn select(&self, available: &[u32]) -> Result<Vec<u32>, String> {
        let picked: Vec<u32> = available.iter().copied().filter(|&n| self.contains(n)).collect();
        if picked.is_empty() {
            return Err(format!(
                "--frames {self} selects none of the frames the scene has ({})",
                describe(available)
            ));
        }
        Ok(picked)
    }
}

/// A short list of frame numbers for messages: `1, 2, 3` or `1 … 240 (240 frames)`.
fn describe(frames: &[u32]) -> String {
    match frames {
        [] => "none".into(),
        [a, .., b] if frames.len() > 6 => format!("{a} … {b}, {} frames", frames.len()),
        _ => frames.iter().map(u32::to_string).collect::<Vec<_>>().join(", "),
    }
}

impl FromStr for FrameSpec {
    type Err = FrameSpecError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::parse(s)
    }
}

impl fmt::Display for FrameSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, &(a, b)) in self.ranges.iter().enumerate() {
            if i > 0 {
                f.write_str(",")?;
            }
            if a == b {
                write!(f, "{a}")?;
            } else {
                write!(f, "{a}-{b}")?;
            }
        }
        Ok(())
    }
}

/// True when the file name of `path` holds a frame-number pattern (a run of `#`, `%d` or `%0Nd`).
#[must_use]
pub fn has_frame_pattern(path: &Path) -> bool {
    path.file_name()
        .and_then(|n| n.to_str())
        .is_some_and(|n| substitute(n, 0).is_some())
}

/// The file frame `frame` writes for the output `path` (see the module docs): the frame-number
/// pattern replaced when the name has one; otherwise `.NNNN` before the extension when `several`
/// frames are rendered; otherwise `path` itself.
#[must_use]
pub fn frame_path(path: &Path, frame: u32, several: bool) -> PathBuf {
    let Some(name) = path.file_name().and_then(|n| n.to_str()) else {
        return path.to_path_buf();
    };
    if let Some(name) = substitute(name, frame) {
        return path.with_file_name(name);
    }
    if !several {
        return path.to_path_buf();
    }
    let numbered = match name.rsplit_once('.') {
        Some((stem, ext)) if !stem.is_empty() => {
            format!("{stem}.{frame:0DEFAULT_PADDING$}.{ext}")
        }
        _ => format!("{name}.{frame:0DEFAULT_PADDING$}"),
    };
    path.with_file_name(numbered)
}

/// The displays frame `frame` writes: each display's path through [`frame_path`].
#[must_use]
pub fn frame_displays(displays: &[Display], frame: u32, several: bool) -> Vec<Display> {
    displays
        .iter()
        .map(|d| Display {
            path: frame_path(&d.path, frame, several),
            ..d.clone()
        })
        .collect()
}

/// `name` with every `#` run and `%d`/`%0Nd` replaced by `frame`, or `None` when it has neither.
fn substitute(name: &str, frame: u32) -> Option<String> {
    let mut out = String::with_capacity(name.len() + 8);
    let mut found = false;
    let mut rest = name;
    while let Some(c) = rest.chars().next() {
        if c == '#' {
            let width = rest.len() - rest.trim_start_matches('#').len();
            out.push_str(&format!("{frame:0width$}"));
            rest = &rest[width..];
            found = true;
        } else if let Some((width, len)) = printf_int(rest) {
            out.push_str(&format!("{frame:0width$}"));
            rest = &rest[len..];
            found = true;
        } else {
            out.push(c);
            rest = &rest[c.len_utf8()..];
        }
    }
    found.then_some(out)
}

/// A printf integer conversion at the start of `s` (`%d`, `%4d`, `%04d`): its minimum width and its
/// length in bytes.
fn printf_int(s: &str) -> Option<(usize, usize)> {
    let body = s.strip_prefix('%')?;
    let digits = body.len() - body.trim_start_matches(|c: char| c.is_ascii_digit()).len();
    if !body[digits..].starts_with('d') || digits > 2 {
        return None;
    }
    let width = if digits == 0 {
        0
    } else {
        body[..digits].parse().ok()?
    };
    Some((width, 1 + digits + 1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn a_number_a_range_and_a_list_are_read() {
        assert_eq!(FrameSpec::parse("7"), Ok(FrameSpec::single(7)));
        assert_eq!(FrameSpec::parse("1-24"), FrameSpec::range(1, 24));
        assert_eq!(FrameSpec::parse(" 3 - 5 "), FrameSpec::range(3, 5));
        assert_eq!(FrameSpec::parse("5-5"), Ok(FrameSpec::single(5)));
        let list = FrameSpec::parse("20,1-10,5-12,13").unwrap();
        assert_eq!(list.to_string(), "1-13,20");
        assert_eq!(
            list.frames().collect::<Vec<_>>(),
            [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 20]
        );
        assert_eq!((list.first(), list.last(), list.len()), (1, 20, 14));
        assert!(list.contains(20) && list.contains(1) && !list.contains(14) && !list.contains(0));
        assert_eq!("0".parse::<FrameSpec>(), Ok(FrameSpec::single(0)));
    }

    #[test]
    fn bad_selections_are_refused_quoting_the_text_and_the_reason() {
        for (bad, reason) in [
            ("", "an empty item"),
            ("1,,2", "an empty item"),
            ("10-1", "the range 10-1 ends before it starts"),
            ("-3", "a frame number is missing"),
            ("3-", "a frame number is missing"),
            ("a", "'a' is not a frame number"),
            ("1.5", "'1.5' is not a frame number"),
            ("1-2-3", "'2-3' is not a frame number"),
            ("99999999999", "'99999999999' is not a frame number"),
        ] {
            let e = FrameSpec::parse(bad).unwrap_err().to_string();
            assert!(e.starts_with(&format!("'{bad}': ")), "{bad}: {e}");
            assert!(e.contains(reason), "{bad}: {e}");
            assert!(e.contains("expected a frame N, a range A-B"), "{bad}: {e}");
        }
        assert!(
            FrameSpec::range(4, 3)
                .unwrap_err()
                .to_string()
                .contains("ends (3) before it starts (4)")
        );
    }

    #[test]
    fn select_keeps_the_files_order_and_names_what_it_has() {
        let spec = FrameSpec::parse("2-3").unwrap();
        assert_eq!(spec.select(&[3, 1, 2]), Ok(vec![3, 2]));
        let e = spec.select(&[1, 4]).unwrap_err();
        assert_eq!(e, "--frames 2-3 selects none of the frames the scene has (1, 4)");
        let e = spec.select(&(10..=250).collect::<Vec<_>>()).unwrap_err();
        assert!(e.ends_with("(10 … 250, 241 frames)"), "{e}");
    }

    #[test]
    fn hash_runs_become_the_padded_frame_number() {
        let p = |s: &str, f: u32, several: bool| frame_path(Path::new(s), f, several);
        assert_eq!(
            p("out/beauty.####.exr", 12, true),
            Path::new("out/beauty.0012.exr")
        );
        assert_eq!(
            p("out/beauty.####.exr", 12, false),
            Path::new("out/beauty.0012.exr")
        );
        assert_eq!(p("f#.png", 12, true), Path::new("f12.png"));
        assert_eq!(p("a##_b###.exr", 7, true), Path::new("a07_b007.exr"));
        assert_eq!(p("shot.##.exr", 12345, true), Path::new("shot.12345.exr"));
        assert_eq!(p("r.%04d.exr", 3, true), Path::new("r.0003.exr"));
        assert_eq!(p("r.%d.exr", 3, false), Path::new("r.3.exr"));
        assert_eq!(p("r.%4d.exr", 3, false), Path::new("r.0003.exr"));
        // Not integer conversions: kept as written, then numbered like any name.
        assert_eq!(p("100%.exr", 3, false), Path::new("100%.exr"));
        assert_eq!(p("r%s.exr", 3, true), Path::new("r%s.0003.exr"));
        // A `#` in a directory is not a pattern.
        assert_eq!(p("take#2/out.exr", 5, true), Path::new("take#2/out.0005.exr"));
        assert!(has_frame_pattern(Path::new("x/y.#.exr")) && has_frame_pattern(Path::new("y.%03d.exr")));
        assert!(!has_frame_pattern(Path::new("take#2/out.exr")));
    }

    #[test]
    fn without_a_pattern_several_frames_are_numbered_before_the_extension() {
        let p = |s: &str, f: u32, several: bool| frame_path(Path::new(s), f, several);
        assert_eq!(p("out.exr", 1, true), Path::new("out.0001.exr"));
        assert_eq!(p("out.exr", 1, false), Path::new("out.exr"));
        assert_eq!(
            p("dir/out.deep.exr", 42, true),
            Path::new("dir/out.deep.0042.exr")
        );
        assert_eq!(p("out", 42, true), Path::new("out.0042"));
        assert_eq!(p(".hidden", 42, true), Path::new(".hidden.0042"));
        assert_eq!(p("out.exr", 123_456, true), Path::new("out.123456.exr"));
    }

    proptest! {
        #[test]
        fn display_reads_back_as_the_same_selection(
            ranges in prop::collection::vec((0u32..500, 0u32..40), 1..6)
        ) {
            let text = ranges
                .iter()
                .map(|&(a, n)| format!("{a}-{}", a + n))
                .collect::<Vec<_>>()
                .join(",");
            let spec = FrameSpec::parse(&text).unwrap();
            prop_assert_eq!(FrameSpec::parse(&spec.to_string()).unwrap(), spec.clone());
            // Membership agrees with the ranges as written.
            for n in 0..560 {
                let inside = ranges.iter().any(|&(a, k)| n >= a && n <= a + k);
                prop_assert_eq!(spec.contains(n), inside);
            }
            let frames: Vec<u32> = spec.frames().collect();
            prop_assert!(frames.windows(2).all(|w| w[0] < w[1]));
            prop_assert_eq!(frames.len() as u64, spec.len());
        }

        #[test]
        fn every_frame_of_a_sequence_gets_its_own_file(a in 0u32..100_000, b in 0u32..100_000) {
            prop_assume!(a != b);
            for name in ["out.exr", "out.####.exr", "o", "x.%03d.png"] {
                let pa = frame_path(Path::new(name), a, true);
                let pb = frame_path(Path::new(name), b, true);
                prop_assert_ne!(pa, pb);
            }
        }
    }
}
