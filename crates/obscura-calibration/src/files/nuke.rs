//! Nuke scripts with 3DEqualizer's lens-distortion nodes (LDPK's `LD_3DE4_*` and
//! `LD_3DE_Classic_LD_Model`, and the LDPK 1 classes `tde4_ldp_*`), as 3DE's "Export Nuke
//! Distortion Nodes", LDPK's test projects and mmSolver write them.
//!
//! A script is read as Nuke reads one: top-level commands, each node a class name followed by a
//! braced body of `knob value` lines. A value is a word (`0.05`), a quoted string, a braced group
//! (`{2.025}`), or an expression `{{curve x1 0.05 x11 -0.05}}`: keys `x<frame> value`, further
//! values on the frames that follow. Curves are evaluated with Nuke's default smooth interpolation
//! (cubic Hermite, slopes `(v₊ − v₋)/(x₊ − x₋)` of the neighbouring keys, the secant to the only
//! neighbour at an end, so two keys are a straight line) and held constant outside their keys.
//!
//! A knob the node does not write takes the **Nuke node's** default (focal length 1 cm, film back
//! 0.8 × 0.6 cm, pixel aspect 1, no offset, field of view 0…1, the model's parameter defaults).
//! Knob names follow LDPK 2 (`Distortion_Degree_2`) or, for the legacy classes, one `_` per
//! character (`Distortion___Degree_2`). Several LD nodes in one script are chosen by their `name`
//! knob (`--camera`). The plate size is the Root node's `format`; a script without one gets a
//! 2048-pixel-wide plate in the film back's aspect (and a note).

use super::{Calibration, CalibrationFileError, FileFormat, Number, PixelConvention, Src, choose_camera};
use crate::lens3de::{Kind, knob_name, legacy_knob_name};

/// One token of a script.
#[derive(Debug, Clone, PartialEq)]
enum Token {
    /// A bare word.
    Word(String),
    /// A quoted string (escapes kept as written, the quotes removed).
    Quoted(String),
    /// A braced group's inner text.
    Group(String),
}

/// Tokens with the line each starts on and whether it is the first on its line.
fn tokenize(
    src: &Src<'_>,
    text: &str,
    first_line: usize,
) -> Result<Vec<(Token, usize, bool)>, CalibrationFileError> {
    let bytes: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let (mut i, mut line, mut line_start) = (0, first_line, true);
    while i < bytes.len() {
        let c = bytes[i];
        if c == '\n' {
            line += 1;
            line_start = true;
            i += 1;
            continue;
        }
        if c.is_whitespace() {
            i += 1;
            continue;
        }
        if c == '#' && line_start {
            while i < bytes.len() && bytes[i] != '\n' {
                i += 1;
            }
            continue;
        }
        let start_line = line;
        let token = match c {
            '{' => {
                let (mut depth, mut j) = (1, i + 1);
                while j < bytes.len() && depth > 0 {
                    match bytes[j] {
                        '\\' => j += 1,
                        '{' => depth += 1,
                        '}' => depth -= 1,
                        '\n' => line += 1,
                        _ => {}
                    }
                    j += 1;
                }
                if depth > 0 {
                    return Err(src.err(start_line, "a '{' is never closed"));
                }
                let inner: String = bytes[i + 1..j - 1].iter().collect();
                i = j;
                Token::Group(inner)
            }
            '"' => {
                let mut j = i + 1;
                while j < bytes.len() && bytes[j] != '"' {
                    if bytes[j] == '\\' {
                        j += 1;
                    }
                    if j < bytes.len() && bytes[j] == '\n' {
                        line += 1;
                    }
                    j += 1;
                }
                if j >= bytes.len() {
                    return Err(src.err(start_line, "a '\"' is never closed"));
                }
                let inner: String = bytes[i + 1..j].iter().collect();
                i = j + 1;
                Token::Quoted(inner)
            }
            '}' => return Err(src.err(line, "a '}' closes nothing")),
            _ => {
                let mut j = i;
                while j < bytes.len() && !bytes[j].is_whitespace() && bytes[j] != '{' && bytes[j] != '"' {
                    if bytes[j] == '\\' {
                        j += 1;
                    }
                    j += 1;
                }
                let word: String = bytes[i..j.min(bytes.len())].iter().collect();
                i = j;
                Token::Word(word)
            }
        };
        out.push((token, start_line, line_start));
        line_start = false;
    }
    Ok(out)
}

/// A knob's value: a constant, or a curve of keys `(frame, value)`.
#[derive(Debug, Clone, PartialEq)]
pub enum KnobValue {
    /// The same on every frame.
    Constant(Number),
    /// Keys in frame order.
    Curve {
        /// `(frame, value)`, frames increasing.
        keys: Vec<(f64, f64)>,
        /// The line of the curve.
        line: usize,
        /// The curve's text.
        text: String,
    },
}

impl KnobValue {
    /// The value at `frame`: Nuke's smooth interpolation between keys, constant outside them.
    #[must_use]
    pub fn at(&self, frame: f64) -> f64 {
        match self {
            KnobValue::Constant(n) => n.value,
            KnobValue::Curve { keys, .. } => smooth(keys, frame),
        }
    }

    fn line(&self) -> usize {
        match self {
            KnobValue::Constant(n) => n.line,
            KnobValue::Curve { line, .. } => *line,
        }
    }
}

/// Nuke's smooth curve through `keys` at `x` (see the module documentation).
fn smooth(keys: &[(f64, f64)], x: f64) -> f64 {
    let n = keys.len();
    if n == 1 || x <= keys[0].0 {
        return keys[0].1;
    }
    if x >= keys[n - 1].0 {
        return keys[n - 1].1;
    }
    let i = keys.windows(2).position(|w| x < w[1].0).unwrap_or(n - 2);
    let slope = |k: usize| {
        let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
        (keys[b].1 - keys[a].1) / (keys[b].0 - keys[a].0)
    };
    let ((x0, y0), (x1, y1)) = (keys[i], keys[i + 1]);
    let h = x1 - x0;
    let t = (x - x0) / h;
    let (t2, t3) = (t * t, t * t * t);
    (2.0 * t3 - 3.0 * t2 + 1.0) * y0
        + (t3 - 2.0 * t2 + t) * h * slope(i)
        + (-2.0 * t3 + 3.0 * t2) * y1
        + (t3 - t2) * h * slope(i + 1)
}

/// Reads a curve expression `curve x1 0.05 x11 -0.05` (also `curve 0.05` and runs of values after
/// one `x`).
fn curve(
    src: &Src<'_>,
    text: &str,
    line: usize,
    knob: &str,
) -> Result<Vec<(f64, f64)>, CalibrationFileError> {
    let bad = |what: String| {
        src.err(
            line,
            format!("knob {knob}: malformed curve {{{{{text}}}}}: {what}"),
        )
    };
    let mut words = text.split_whitespace();
    match words.next() {
        Some("curve") => {}
        other => {
            return Err(bad(format!(
                "expected an animation curve {{{{curve x<frame> <value> …}}}}, got an expression starting with {:?}",
                other.unwrap_or("")
            )));
        }
    }
    let (mut keys, mut frame): (Vec<(f64, f64)>, f64) = (Vec::new(), 1.0);
    let mut pending: Option<&str> = None;
    for w in words {
        if let Some(x) = w.strip_prefix('x') {
            if let Some(p) = pending {
                return Err(bad(format!("{p} has no value")));
            }
            pending = Some(w);
            frame = x
                .parse::<f64>()
                .ok()
                .filter(|f| f.is_finite())
                .ok_or_else(|| bad(format!("\"{w}\" is not a frame")))?;
            continue;
        }
        let v = w.parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(|| {
            bad(format!(
                "\"{w}\" is neither x<frame> nor a value (only keyed values are read)"
            ))
        })?;
        if let Some(&(last, _)) = keys.last()
            && frame <= last
        {
            return Err(bad(format!("frame {frame} does not follow frame {last}")));
        }
        keys.push((frame, v));
        pending = None;
        frame += 1.0;
    }
    if let Some(p) = pending {
        return Err(bad(format!("{p} has no value")));
    }
    if keys.is_empty() {
        return Err(bad("no keys".to_string()));
    }
    Ok(keys)
}

/// One node of a script: its class, the line it starts on, and its knobs in order.
#[derive(Debug, Clone)]
struct Node {
    class: String,
    line: usize,
    knobs: Vec<(String, Vec<(Token, usize)>)>,
}

/// The top-level nodes of a script.
fn nodes(src: &Src<'_>, text: &str) -> Result<Vec<Node>, CalibrationFileError> {
    let tokens = tokenize(src, text, 1)?;
    let mut out = Vec::new();
    for k in 0..tokens.len() {
        let (Token::Group(body), line, _) = &tokens[k] else {
            continue;
        };
        let Some((Token::Word(class), _, _)) = k.checked_sub(1).map(|j| &tokens[j]) else {
            continue;
        };
        if !(class.starts_with("LD_3DE") || class.starts_with("tde4_ldp_") || class == "Root") {
            continue;
        }
        let mut knobs: Vec<(String, Vec<(Token, usize)>)> = Vec::new();
        for (t, l, first) in tokenize(src, body, *line)? {
            if first {
                let name = match t {
                    Token::Word(w) => w,
                    Token::Quoted(q) => q,
                    Token::Group(_) => {
                        return Err(src.err(l, format!("{class}: a knob line starts with a braced group")));
                    }
                };
                knobs.push((name, Vec::new()));
            } else if let Some(last) = knobs.last_mut() {
                last.1.push((t, l));
            }
        }
        out.push(Node {
            class: class.clone(),
            line: *line,
            knobs,
        });
    }
    Ok(out)
}

/// The model of an LD node class (LDPK 2 and LDPK 1 names), and whether its knobs are legacy.
fn model_of_class(class: &str) -> Option<(Kind, bool)> {
    if let Some(k) = crate::lens3de::KINDS.iter().find(|k| k.nuke_class() == class) {
        return Some((*k, false));
    }
    let legacy = match class {
        "tde4_ldp_classic_3de_mixed" => Kind::Classic,
        "tde4_ldp_radial_decentered_deg_4" | "tde4_ldp_radial_decentered_deg_4_cylindric" => {
            Kind::RadialStandard4
        }
        "tde4_ldp_anamorphic_deg_4_rotate_squeeze_xy" => Kind::AnamorphicStandard4,
        "tde4_ldp_anamorphic_deg_4_rotate_squeeze_xy_rescaled" => Kind::AnamorphicRescaled4,
        "tde4_ldp_anamorphic_deg_6" => Kind::Anamorphic6,
        "tde4_ldp_radial_deg_8" => Kind::RadialFisheye8,
        _ => return None,
    };
    Some((legacy, true))
}

/// A knob's value from its tokens.
fn value(
    src: &Src<'_>,
    knob: &str,
    tokens: &[(Token, usize)],
    line: usize,
) -> Result<KnobValue, CalibrationFileError> {
    let what = format!("knob {knob}");
    match tokens {
        [(Token::Word(w), l)] => Ok(KnobValue::Constant(src.number(w, *l, &what)?)),
        [(Token::Group(g), l)] => {
            let inner = g.trim();
            if let Some(expr) = inner.strip_prefix('{').and_then(|e| e.strip_suffix('}')) {
                let keys = curve(src, expr.trim(), *l, knob)?;
                Ok(KnobValue::Curve {
                    keys,
                    line: *l,
                    text: expr.trim().to_string(),
                })
            } else {
                Ok(KnobValue::Constant(src.number(inner, *l, &what)?))
            }
        }
        [] => Err(src.err(line, format!("{what}: no value"))),
        [(_, l), ..] => Err(src.err(*l, format!("{what}: expected a number or {{{{curve …}}}}"))),
    }
}

/// Reads the LD node `camera` (its `name` knob; default the first) of a Nuke script, its animated
/// knobs at `frame` (default: the Root node's `frame`, else 1).
///
/// # Errors
/// A [`CalibrationFileError`] at the line to blame: no LD node, no node of that name, a node class
/// of no known model, a malformed value or curve, a parameter out of its range.
pub(crate) fn read(
    src: &Src<'_>,
    text: &str,
    camera: Option<&str>,
    frame: Option<f64>,
) -> Result<Calibration, CalibrationFileError> {
    let all = nodes(src, text)?;
    let root = all.iter().find(|n| n.class == "Root");
    let lds: Vec<&Node> = all.iter().filter(|n| n.class != "Root").collect();
    let names: Vec<String> = lds
        .iter()
        .enumerate()
        .map(|(i, n)| {
            n.knobs
                .iter()
                .find(|k| k.0 == "name")
                .and_then(|k| match k.1.first() {
                    Some((Token::Word(w) | Token::Quoted(w), _)) => Some(w.clone()),
                    _ => None,
                })
                .unwrap_or_else(|| format!("{}{}", n.class, i + 1))
        })
        .collect();
    if lds.is_empty() {
        return Err(src.whole(
            "no 3DEqualizer lens-distortion node in this Nuke script (expected a node LD_3DE4_… or LD_3DE_Classic_LD_Model, or LDPK 1's tde4_ldp_…)",
        ));
    }
    let (index, by_default) = choose_camera(src, "Nuke script's LD nodes", &names, camera)?;
    let node = lds[index];
    let (kind, legacy) = model_of_class(&node.class).ok_or_else(|| {
        src.err(
            node.line,
            format!(
                "unknown lens-distortion node class {}: expected one of {}",
                node.class,
                crate::lens3de::KINDS
                    .iter()
                    .map(|k| k.nuke_class())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        )
    })?;
    let root_knob = |name: &str| root.and_then(|r| r.knobs.iter().find(|k| k.0 == name));
    let frame = match frame {
        Some(f) => f,
        None => match root_knob("frame") {
            Some((k, t)) => value(src, k, t, root.map_or(1, |r| r.line))?.at(1.0),
            None => 1.0,
        },
    };
    let mut notes = Vec::new();
    let mut params = Vec::new();
    let mut animated = Vec::new();
    for (name, default) in kind.all_params() {
        let knob = if name.starts_with("tde4_") || name.starts_with("field_of_view") {
            name.to_string()
        } else if legacy {
            legacy_knob_name(name)
        } else {
            knob_name(name)
        };
        let number = match node.knobs.iter().find(|k| k.0 == knob) {
            Some((k, tokens)) => {
                let v = value(src, k, tokens, node.line)?;
                if let KnobValue::Curve { text, .. } = &v {
                    animated.push(format!("{knob} ({{{{{text}}}}})"));
                }
                let x = v.at(frame);
                Number {
                    text: format!("{x}"),
                    value: x,
                    line: v.line(),
                }
            }
            None => Number {
                text: format!("{default}"),
                value: default,
                line: node.line,
            },
        };
        params.push(number);
    }
    if !animated.is_empty() {
        notes.push(format!(
            "at frame {frame}: animated knobs {}",
            animated.join(", ")
        ));
    }
    let (width, height) = match root_knob("format") {
        Some((_, t)) => match t.first() {
            Some((Token::Quoted(f) | Token::Word(f), l)) => {
                let mut w = f.split_whitespace();
                let width = src.size(w.next().unwrap_or(""), *l, "Root format width")?;
                let height = src.size(w.next().unwrap_or(""), *l, "Root format height")?;
                (width, height)
            }
            _ => return Err(src.err(root.map_or(1, |r| r.line), "Root format: expected \"W H …\"")),
        },
        None => {
            let (w, h, note) = plate_of_back(&params, "the script names no Root format");
            notes.push(note);
            (w, h)
        }
    };
    let mut c = src.calibration(FileFormat::Nuke, node.line, kind.name(), [width, height], params);
    c.pixel_convention = PixelConvention::Colmap;
    c.camera = Some(names[index].clone());
    c.cameras = names;
    c.first_by_default = by_default;
    c.animated = !animated.is_empty();
    c.notes = notes;
    Ok(c)
}

/// A plate for a lens file that names none: 2048 pixels wide in the aspect of the film back
/// (`params` in [`Kind::all_params`] order, `w_fb/(h_fb·pa)`), with the note saying so after `why`.
pub(crate) fn plate_of_back(params: &[Number], why: &str) -> (u32, u32, String) {
    let (wfb, hfb, pa) = (params[1].value, params[2].value, params[5].value);
    let w = 2048u32;
    let h = if wfb > 0.0 && hfb > 0.0 && pa > 0.0 {
        ((f64::from(w) * hfb * pa / wfb).round() as u32).max(1)
    } else {
        w
    };
    let note = format!(
        "{why}: a {w}x{h} plate in the film back's aspect (3DE's model is in unit coordinates, so any size of that aspect is the same lens; choose another with --format)"
    );
    (w, h, note)
}

/// True when `text` looks like a Nuke script holding a 3DE lens node.
#[must_use]
pub fn looks_like(text: &str) -> bool {
    text.lines().any(|l| {
        let l = l.trim_start();
        (l.starts_with("LD_3DE") || l.starts_with("tde4_ldp_")) && l.trim_end().ends_with('{')
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_keys_are_a_line_and_runs_follow_their_x() {
        let src = Src { file: "t.nk" };
        let k = curve(&src, "curve x1 4 x11 6", 1, "k").unwrap();
        let run = curve(&src, "curve x1 4 4.2 4.4 4.6 4.8 5 5.2 5.4 5.6 5.8 6", 1, "k").unwrap();
        for f in 1..=11 {
            let x = f64::from(f);
            assert!((smooth(&k, x) - smooth(&run, x)).abs() < 1e-12, "frame {f}");
        }
        assert_eq!(smooth(&k, 0.0), 4.0);
        assert_eq!(smooth(&k, 20.0), 6.0);
        // Interior keys: the curve passes through each and is smooth (C¹) there.
        let c = [(1.0, 0.0), (5.0, 2.0), (6.0, -1.0)];
        assert_eq!(smooth(&c, 5.0), 2.0);
        let e = 1e-6;
        let left = (smooth(&c, 5.0) - smooth(&c, 5.0 - e)) / e;
        let right = (smooth(&c, 5.0 + e) - smooth(&c, 5.0)) / e;
        assert!((left - right).abs() < 1e-4);
    }

    #[test]
    fn malformed_curves_are_located() {
        let src = Src { file: "t.nk" };
        let text = "LD_3DE4_Radial_Standard_Degree_4 {\n tde4_focal_length_cm 3\n Distortion_Degree_2 {{curve x1 0.1 x1 zz}}\n name a\n}\n";
        let e = read(&src, text, None, None).unwrap_err();
        assert_eq!(e.line, Some(3), "{e}");
        assert!(
            e.message.contains("Distortion_Degree_2") && e.message.contains("zz"),
            "{e}"
        );
    }
}

/// An LDPK Nuke node for a 3DE model: the node class of `kind`, `direction` (`distort` or
/// `undistort`), then the built-in knobs, the field-of-view knobs and the model's knobs with 7
/// decimals (as 3DE's "Export Nuke Distortion Nodes" writes them), and `name`. `params` are in
/// [`Kind::all_params`] order (as `CalibratedCamera`'s `params`).
///
/// # Errors
/// A message when `params` does not have the model's count.
pub fn write_node(kind: Kind, params: &[f64], name: &str, direction: &str) -> Result<String, String> {
    let all = kind.all_params();
    if params.len() != all.len() {
        return Err(format!(
            "model {}: takes {} params, got {}",
            kind.name(),
            all.len(),
            params.len()
        ));
    }
    let mut out = format!("{} {{\n direction {direction}\n", kind.nuke_class());
    for ((knob, _), v) in all.iter().zip(params) {
        let knob = if knob.starts_with("tde4_") || knob.starts_with("field_of_view") {
            (*knob).to_string()
        } else {
            knob_name(knob)
        };
        out.push_str(&format!(" {knob} {v:.7}\n"));
    }
    let quoted = name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    if quoted {
        out.push_str(&format!(" name {name}\n}}\n"));
    } else {
        out.push_str(&format!(" name \"{}\"\n}}\n", name.replace('"', "\\\"")));
    }
    Ok(out)
}

#[cfg(test)]
mod write_tests {
    use super::*;

    #[test]
    fn a_written_node_reads_back_as_the_same_lens() {
        for kind in crate::lens3de::KINDS {
            let params: Vec<f64> = kind
                .all_params()
                .iter()
                .enumerate()
                .map(|(i, &(n, d))| match n {
                    "tde4_focal_length_cm" => 3.5,
                    "tde4_filmback_width_cm" => 2.4,
                    "tde4_filmback_height_cm" => 1.35,
                    _ if i >= 10 && d == 0.0 => 0.001 * i as f64,
                    _ => d,
                })
                .collect();
            let text = write_node(kind, &params, "lens_1", "distort").unwrap();
            let src = Src { file: "w.nk" };
            let c = read(&src, &text, Some("lens_1"), None).unwrap();
            assert_eq!(c.model, kind.name());
            for (a, b) in c.params.iter().zip(&params) {
                assert!((a.value - b).abs() < 1e-12, "{kind:?}: {a:?} vs {b}");
            }
        }
    }
}
