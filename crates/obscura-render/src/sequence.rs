//! Frame sequences: which frames to render (`--frames 12`, `--frames 1-24`, `--frames 1-10,20`, and
//! the forms farms emit: `1-24:6`, `1-24x3`, `1-3,5,7-20:2`, `-5--1`) and the file each frame writes.
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

/// A selection of frames as farms write it: one number `N`, an inclusive range `A-B`, a stepped
/// range `A-B:S` (Slurm, Open Job Description) or `A-BxS` (OpenCue, Qube) — `A`, `A+S`, … up to
/// `B` —, or a comma-separated list of any of these (`1-3,5,7-20:2`). Numbers may be negative
/// (`-10--1`). Kept sorted, with overlapping and adjacent ranges merged.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct FrameSpec {
    /// Disjoint inclusive ranges in increasing order, none adjacent to the next.
    ranges: Vec<(i32, i32)>,
}

/// The most frames the stepped items of one selection may name (each is kept as a range of its own).
pub const MAX_STEPPED_FRAMES: u64 = 1_000_000;

/// Why a frame selection could not be read: the text as given, the item at fault and what was
/// expected.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "'{text}': {reason}; expected a frame N, a range A-B, a stepped range A-B:S or A-BxS, or a comma-separated list of them, e.g. 1-24 or 1-3,5,7-20:2"
)]
pub struct FrameSpecError {
    /// The selection as written.
    pub text: String,
    /// The comma-separated item at fault, as written (trimmed); empty for an empty item.
    pub token: String,
    /// What is wrong with it (quoting the item).
    pub reason: String,
}

/// One comma-separated item, read: first, last, step.
fn parse_item(item: &str) -> Result<(i32, i32, u32), String> {
    let quoted = format!("'{item}'");
    let bad = |what: &str| format!("{quoted}: {what}");
    // The step: after the first ':' or 'x' (neither can appear in a number), all the rest of the item.
    let (range, step) = match item.find([':', 'x']) {
        Some(i) => {
            let sep = &item[i..=i];
            let s = item[i + 1..].trim();
            let step = match s.parse::<u32>() {
                Ok(0) => return Err(bad("the step must be at least 1")),
                Ok(n) => n,
                Err(_) if s.is_empty() => return Err(bad(&format!("the step after '{sep}' is missing"))),
                Err(_) => return Err(bad(&format!("the step '{s}' is not a positive integer"))),
            };
            (&item[..i], Some(step))
        }
        None => (item, None),
    };
    let number = |s: &str| -> Result<i32, String> {
        let s = s.trim();
        if s.is_empty() {
            return Err(bad("a frame number is missing"));
        }
        let digits = s.strip_prefix('-').unwrap_or(s);
        if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
            return Err(bad(&format!("'{s}' is not a frame number (an integer)")));
        }
        s.parse::<i32>().map_err(|_| {
            bad(&format!(
                "'{s}' is out of range (frame numbers are from {} to {})",
                i32::MIN,
                i32::MAX
            ))
        })
    };
    // The dash between the two numbers: the first '-' after the first character that is not a
    // space or the first number's own sign.
    let body = range.trim();
    let start = usize::from(body.starts_with('-'));
    let (first, last) = match body[start..].find('-') {
        Some(i) => (number(&body[..start + i])?, number(&body[start + i + 1..])?),
        None => {
            let n = number(body)?;
            if step.is_some() {
                return Err(bad("a step needs a range A-B before it"));
            }
            (n, n)
        }
    };
    if last < first {
        return Err(bad(&format!(
            "the range ends ({last}) before it starts ({first})"
        )));
    }
    Ok((first, last, step.unwrap_or(1)))
}

impl FrameSpec {
    /// Frame `n` alone.
    #[must_use]
    pub fn single(n: i32) -> Self {
        FrameSpec { ranges: vec![(n, n)] }
    }

    /// Frames `first..=last`.
    ///
    /// # Errors
    /// When `last < first`.
    pub fn range(first: i32, last: i32) -> Result<Self, FrameSpecError> {
        if last < first {
            let text = format!("{first}-{last}");
            return Err(FrameSpecError {
                reason: format!("'{text}': the range ends ({last}) before it starts ({first})"),
                token: text.clone(),
                text,
            });
        }
        Ok(FrameSpec {
            ranges: vec![(first, last)],
        })
    }

    /// Reads a selection (see [`FrameSpec`]); spaces around numbers, dashes, steps and commas are
    /// allowed.
    ///
    /// # Errors
    /// A [`FrameSpecError`] quoting `text` and the item at fault and saying what is wrong: an empty
    /// item, something that is not an integer, a number beyond 32 bits, a range that ends before it
    /// starts, a step of 0 or on a single number, or stepped items naming more than
    /// [`MAX_STEPPED_FRAMES`] frames.
    pub fn parse(text: &str) -> Result<Self, FrameSpecError> {
        // A selection of one item names it once: `'1-3:x': the step …`, not `'1-3:x': '1-3:x': …`.
        let fail = |token: &str, reason: String| FrameSpecError {
            text: text.to_string(),
            token: token.to_string(),
            reason: match reason.strip_prefix(&format!("'{token}': ")) {
                Some(what) if token == text.trim() => what.to_string(),
                _ => reason,
            },
        };
        let mut ranges = Vec::new();
        let mut stepped: u64 = 0;
        for (k, item) in text.split(',').enumerate() {
            let item = item.trim();
            if item.is_empty() {
                return Err(fail(item, format!("'' (item {}): an empty item", k + 1)));
            }
            let (first, last, step) = parse_item(item).map_err(|reason| fail(item, reason))?;
            if step == 1 {
                ranges.push((first, last));
                continue;
            }
            let count = (i64::from(last) - i64::from(first)) as u64 / u64::from(step) + 1;
            stepped += count;
            if stepped > MAX_STEPPED_FRAMES {
                return Err(fail(
                    item,
                    format!("'{item}': stepped ranges may name at most {MAX_STEPPED_FRAMES} frames"),
                ));
            }
            let mut n = i64::from(first);
            while n <= i64::from(last) {
                // In range: first <= n <= last.
                ranges.push((n as i32, n as i32));
                n += i64::from(step);
            }
        }
        Ok(Self::normalized(ranges))
    }

    /// Sorts and merges overlapping or adjacent ranges.
    fn normalized(mut ranges: Vec<(i32, i32)>) -> Self {
        ranges.sort_unstable();
        let mut merged: Vec<(i32, i32)> = Vec::with_capacity(ranges.len());
        for (a, b) in ranges {
            match merged.last_mut() {
                Some(last) if i64::from(a) <= i64::from(last.1) + 1 => last.1 = last.1.max(b),
                _ => merged.push((a, b)),
            }
        }
        FrameSpec { ranges: merged }
    }

    /// True when frame `n` is selected.
    #[must_use]
    pub fn contains(&self, n: i64) -> bool {
        let i = self.ranges.partition_point(|&(_, b)| i64::from(b) < n);
        self.ranges.get(i).is_some_and(|&(a, _)| i64::from(a) <= n)
    }

    /// The first frame selected.
    #[must_use]
    pub fn first(&self) -> i32 {
        self.ranges[0].0
    }

    /// The last frame selected.
    #[must_use]
    pub fn last(&self) -> i32 {
        self.ranges[self.ranges.len() - 1].1
    }

    /// How many frames are selected.
    #[must_use]
    pub fn len(&self) -> u64 {
        self.ranges
            .iter()
            .map(|&(a, b)| (i64::from(b) - i64::from(a) + 1) as u64)
            .sum()
    }

    /// Never true: a selection holds at least one frame (kept for the `len`/`is_empty` pair).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.ranges.is_empty()
    }

    /// The selected frames in increasing order.
    pub fn frames(&self) -> impl Iterator<Item = i32> + '_ {
        self.ranges.iter().flat_map(|&(a, b)| a..=b)
    }

    /// The selected frames in increasing order, for scenes whose frames are numbered from 0.
    ///
    /// # Errors
    /// When the selection holds a negative frame: a message naming the selection.
    pub fn non_negative(&self) -> Result<impl Iterator<Item = u32> + '_, String> {
        if self.first() < 0 {
            return Err(format!(
                "--frames {self} selects negative frames (from {}); this scene's frames are numbered from 0",
                self.first()
            ));
        }
        // Every frame is >= 0 here.
        Ok(self.frames().map(|n| n as u32))
    }

    /// The selection cut into consecutive runs of at most `size` selected frames each, in order
    /// (what one task of a farm job renders when frames are chunked `size` at a time).
    ///
    /// # Panics
    /// When `size` is 0.
    #[must_use]
    pub fn chunks(&self, size: u32) -> Vec<FrameSpec> {
        assert!(size > 0, "a chunk holds at least one frame");
        let mut out = Vec::new();
        let mut current: Vec<(i32, i32)> = Vec::new();
        let mut held: u64 = 0;
        for &(a, b) in &self.ranges {
            let mut start = i64::from(a);
            while start <= i64::from(b) {
                let room = u64::from(size) - held;
                let end = (start + room as i64 - 1).min(i64::from(b));
                // Both within [a, b].
                current.push((start as i32, end as i32));
                held += (end - start + 1) as u64;
                if held == u64::from(size) {
                    out.push(FrameSpec {
                        ranges: std::mem::take(&mut current),
                    });
                    held = 0;
                }
                start = end + 1;
            }
        }
        if !current.is_empty() {
            out.push(FrameSpec { ranges: current });
        }
        out
    }

    /// The frames of `available` (the frame numbers a file holds, in file order) that are selected,
    /// in file order.
    ///
    /// # Errors
    /// When none is: a message naming the selection and the frames the file has.
    pub fn select(&self, available: &[u32]) -> Result<Vec<u32>, String> {
        let picked: Vec<u32> = (available.iter().copied())
            .filter(|&n| self.contains(i64::from(n)))
            .collect();
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
    /// The canonical form: ranges `A-B`, single frames `N`, and three or more equally spaced single
    /// frames as `A-B:S`; reading it back gives the same selection.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = &self.ranges;
        let mut i = 0;
        let mut sep = "";
        while i < r.len() {
            f.write_str(sep)?;
            sep = ",";
            let (a, b) = r[i];
            if a != b {
                write!(f, "{a}-{b}")?;
                i += 1;
                continue;
            }
            // A run of single frames with one spacing.
            let mut j = i + 1;
            if j < r.len() && r[j].0 == r[j].1 {
                let step = i64::from(r[j].0) - i64::from(a);
                while j + 1 < r.len()
                    && r[j + 1].0 == r[j + 1].1
                    && i64::from(r[j + 1].0) - i64::from(r[j].0) == step
                {
                    j += 1;
                }
                if j - i >= 2 {
                    write!(f, "{a}-{}:{step}", r[j].0)?;
                    i = j + 1;
                    continue;
                }
            }
            write!(f, "{a}")?;
            i += 1;
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

/// The displays frame `frame` writes: each display's path through [`frame_path`] (for a sequence
/// of images that may share names, [`sequence_displays`]).
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

/// The displays each image of a sequence writes, given each image's frame number and displays in
/// render order.
///
/// A frame-number pattern in a name is always replaced by the image's frame number. A file named
/// by more than one image (as `-o out.exr` names one for all, or a scene naming one file in every
/// frame) is numbered by frame, `out.0001.exr`, or, when those images share a frame number too (a
/// shadow pass and a beauty pass in one frame), by the image's position in the sequence (from 1).
/// Names only one image uses are kept as they are.
#[must_use]
pub fn sequence_displays(images: &[(u32, Vec<Display>)]) -> Vec<Vec<Display>> {
    let users = |path: &Path| -> Vec<usize> {
        (0..images.len())
            .filter(|&i| images[i].1.iter().any(|d| d.path == path))
            .collect()
    };
    images
        .iter()
        .enumerate()
        .map(|(i, (number, displays))| {
            displays
                .iter()
                .map(|d| {
                    let sharing = users(&d.path);
                    let path = if has_frame_pattern(&d.path) || sharing.len() < 2 {
                        frame_path(&d.path, *number, false)
                    } else {
                        let same_number = sharing.iter().filter(|&&j| images[j].0 == *number).count() > 1;
                        let key = if same_number {
                            u32::try_from(i + 1).unwrap_or(u32::MAX)
                        } else {
                            *number
                        };
                        frame_path(&d.path, key, true)
                    };
                    Display { path, ..d.clone() }
                })
                .collect()
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
    fn bad_selections_are_refused_quoting_the_text_the_item_and_the_reason() {
        for (bad, token, reason) in [
            ("", "", "an empty item"),
            ("1,,2", "", "an empty item"),
            ("10-1", "10-1", "the range ends (1) before it starts (10)"),
            ("-", "-", "'-' is not a frame number"),
            ("3-", "3-", "a frame number is missing"),
            ("a", "a", "'a' is not a frame number"),
            ("1.5", "1.5", "'1.5' is not a frame number"),
            ("1-2-3", "1-2-3", "'2-3' is not a frame number"),
            ("99999999999", "99999999999", "'99999999999' is out of range"),
            ("1-24:0", "1-24:0", "the step must be at least 1"),
            ("1,5-24x", "5-24x", "the step after 'x' is missing"),
            ("1-3:x", "1-3:x", "the step 'x' is not a positive integer"),
            ("1-24:-2", "1-24:-2", "the step '-2' is not a positive integer"),
            ("1-24:6x2", "1-24:6x2", "the step '6x2' is not a positive integer"),
            ("1-3,7:2", "7:2", "a step needs a range A-B before it"),
            ("0-2000000:1,1-2000001:2", "1-2000001:2", "at most 1000000 frames"),
        ] {
            let e = FrameSpec::parse(bad).unwrap_err();
            assert_eq!(e.token, token, "{bad}: {e}");
            let e = e.to_string();
            if token == bad && !bad.is_empty() {
                // One item: named once.
                assert!(e.starts_with(&format!("'{bad}': ")), "{bad}: {e}");
                assert!(!e.starts_with(&format!("'{bad}': '{bad}': ")), "{bad}: {e}");
            } else {
                assert!(e.starts_with(&format!("'{bad}': '{token}'")), "{bad}: {e}");
            }
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
    fn farm_forms_steps_and_negative_frames_are_read() {
        let frames = |s: &str| FrameSpec::parse(s).unwrap().frames().collect::<Vec<_>>();
        assert_eq!(frames("1-24:6"), [1, 7, 13, 19]);
        assert_eq!(frames("1-24x6"), [1, 7, 13, 19]);
        assert_eq!(frames("1-3,5,7-20:2"), [1, 2, 3, 5, 7, 9, 11, 13, 15, 17, 19]);
        assert_eq!(frames("-3--1"), [-3, -2, -1]);
        assert_eq!(frames("-2-1"), [-2, -1, 0, 1]);
        assert_eq!(frames(" -4 - -2 : 2 "), [-4, -2]);
        assert_eq!(frames("5-5:3"), [5]);
        assert_eq!(FrameSpec::parse("1-24:6").unwrap().to_string(), "1-19:6");
        assert_eq!(
            FrameSpec::parse("1-3,5,7-20:2").unwrap().to_string(),
            "1-3,5-19:2"
        );
        assert_eq!(FrameSpec::parse("1,3").unwrap().to_string(), "1,3");
        let all = FrameSpec::parse("-2147483648-2147483647").unwrap();
        assert_eq!(all.len(), 1 << 32);
        assert!(all.contains(-2_147_483_648) && !all.contains(1 << 31));
        let e = FrameSpec::parse("-3-2").unwrap().non_negative().err().unwrap();
        assert!(e.contains("negative frames (from -3)"), "{e}");
    }

    #[test]
    fn chunks_cut_the_selection_in_order() {
        let chunks = |s: &str, n: u32| {
            let spec = FrameSpec::parse(s).unwrap();
            spec.chunks(n).iter().map(ToString::to_string).collect::<Vec<_>>()
        };
        assert_eq!(chunks("1-24", 6), ["1-6", "7-12", "13-18", "19-24"]);
        assert_eq!(chunks("1-10", 4), ["1-4", "5-8", "9-10"]);
        assert_eq!(chunks("1-3,5,7-20:2", 4), ["1-3,5", "7-13:2", "15-19:2"]);
    }

    /// One item of a selection as a farm would write it, from its parts.
    fn item() -> impl Strategy<Value = String> {
        (-50i32..50, 0i32..40, 1u32..7, 0u8..4).prop_map(|(a, len, step, form)| match form {
            0 => format!("{a}"),
            1 => format!("{a}-{}", a + len),
            2 => format!("{a}-{}:{step}", a + len),
            _ => format!("{a}-{}x{step}", a + len),
        })
    }

    /// The frames of a list of items, computed independently of the parser.
    fn expected(items: &[String]) -> std::collections::BTreeSet<i32> {
        let mut set = std::collections::BTreeSet::new();
        for it in items {
            let (range, step) = match it.split_once([':', 'x']) {
                Some((r, s)) => (r, s.parse::<i32>().unwrap()),
                None => (it.as_str(), 1),
            };
            let sign = usize::from(range.starts_with('-'));
            let (a, b) = match range[sign..].find('-') {
                Some(i) => (&range[..sign + i], &range[sign + i + 1..]),
                None => (range, range),
            };
            let (a, b): (i32, i32) = (a.parse().unwrap(), b.parse().unwrap());
            set.extend((a..=b).step_by(step as usize));
        }
        set
    }

    proptest! {
        #[test]
        fn every_accepted_selection_is_its_frames_and_round_trips(items in prop::collection::vec(item(), 1..6)) {
            let text = items.join(",");
            let spec = FrameSpec::parse(&text).unwrap();
            let want = expected(&items);
            prop_assert_eq!(spec.frames().collect::<Vec<_>>(), want.iter().copied().collect::<Vec<_>>());
            prop_assert_eq!(spec.len(), want.len() as u64);
            let again = FrameSpec::parse(&spec.to_string()).unwrap();
            prop_assert_eq!(&again, &spec);
            prop_assert_eq!(again.to_string(), spec.to_string());
            for n in -60..100 {
                prop_assert_eq!(spec.contains(n), want.contains(&(n as i32)));
            }
            let chunks = spec.chunks(5);
            let joined: Vec<i32> = chunks.iter().flat_map(|c| c.frames().collect::<Vec<_>>()).collect();
            prop_assert_eq!(joined, want.iter().copied().collect::<Vec<_>>());
            prop_assert!(chunks.iter().all(|c| c.len() <= 5));
        }

        #[test]
        fn every_rejected_selection_names_its_item(
            items in prop::collection::vec(item(), 0..4),
            bad in prop_oneof![
                Just("".to_string()), Just("a".to_string()), Just("1-".to_string()),
                Just("5-1".to_string()), Just("1-9:0".to_string()), Just("3x2".to_string()),
                Just("1--".to_string()), Just("1.0".to_string()), Just("1-9:y".to_string()),
                Just("4294967296".to_string()), Just("2-1x3".to_string()),
            ],
            at in 0usize..4,
        ) {
            let mut all = items.clone();
            all.insert(at.min(items.len()), bad.clone());
            let text = all.join(",");
            let e = FrameSpec::parse(&text).unwrap_err();
            prop_assert_eq!(&e.token, &bad);
            let quoted = format!("'{bad}'");
            prop_assert!(e.to_string().contains(&quoted), "{}", e);
        }
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

    fn display(path: &str) -> Display {
        Display {
            path: PathBuf::from(path),
            driver: obscura_scene::DisplayDriver::OpenExr,
            aovs: vec![obscura_scene::Aov::Ci],
            half: false,
        }
    }

    fn paths(lists: &[Vec<Display>]) -> Vec<Vec<String>> {
        lists
            .iter()
            .map(|l| l.iter().map(|d| d.path.display().to_string()).collect())
            .collect()
    }

    #[test]
    fn a_sequence_numbers_only_the_files_several_images_name() {
        // Frames 4 and 5 each name their own beauty and share "depth.exr"; a pattern is replaced.
        let got = sequence_displays(&[
            (
                4,
                vec![display("b4.exr"), display("depth.exr"), display("m.##.exr")],
            ),
            (
                5,
                vec![display("b5.exr"), display("depth.exr"), display("m.##.exr")],
            ),
        ]);
        assert_eq!(
            paths(&got),
            [
                ["b4.exr", "depth.0004.exr", "m.04.exr"],
                ["b5.exr", "depth.0005.exr", "m.05.exr"]
            ]
        );
        // Two images of one frame naming one file: numbered by their place.
        let got = sequence_displays(&[
            (1, vec![display("o.exr")]),
            (1, vec![display("o.exr")]),
            (2, vec![display("x.exr")]),
        ]);
        assert_eq!(paths(&got), [["o.0001.exr"], ["o.0002.exr"], ["x.exr"]]);
        // frame_displays numbers every name of one frame.
        assert_eq!(
            paths(&[frame_displays(&[display("o.exr")], 3, true)]),
            [["o.0003.exr"]]
        );
        // One image: names as given.
        assert_eq!(
            paths(&sequence_displays(&[(9, vec![display("o.exr")])])),
            [["o.exr"]]
        );
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
                prop_assert_eq!(spec.contains(n.into()), inside);
            }
            let frames: Vec<i32> = spec.frames().collect();
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
