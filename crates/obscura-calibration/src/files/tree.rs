//! A YAML or JSON document as a small tree that keeps what calibration readers need: each scalar's
//! text exactly as written (so `5.3591573396163199e+02` reaches the projection digit for digit), each
//! node's line (for errors naming `file:line`), and tags (OpenCV's `!!opencv-matrix`).
//!
//! The events come from `saphyr-parser`, a YAML 1.2 parser; JSON is YAML 1.2 flow style, so OpenCV's
//! FileStorage JSON reads through the same path, including its non-JSON numbers such as `1.`. OpenCV's
//! `%YAML:1.0` header is not a YAML 1.2 directive; it is blanked to a comment before parsing (line
//! numbers unchanged).

use saphyr_parser::{Event, Parser, ScalarStyle};

use super::{CalibrationFileError, Src};

/// What a node holds.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Value {
    /// A scalar, as written (quotes removed).
    Scalar {
        /// The text.
        text: String,
        /// True when it was quoted: a string, never a number.
        quoted: bool,
    },
    /// A sequence.
    Seq(Vec<Node>),
    /// A mapping, in file order: (key text, key line, value).
    Map(Vec<(String, Node)>),
}

/// One node and where it starts.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Node {
    /// The content.
    pub value: Value,
    /// 1-based line of the node's first character.
    pub line: usize,
    /// The tag's suffix, if tagged (`opencv-matrix` for `!!opencv-matrix`).
    pub tag: Option<String>,
}

impl Node {
    /// The value under `key` in a mapping (exact spelling).
    pub fn get(&self, key: &str) -> Option<&Node> {
        match &self.value {
            Value::Map(entries) => entries.iter().find(|(k, _)| k == key).map(|(_, v)| v),
            _ => None,
        }
    }

    /// The value under `key` in a mapping, ignoring ASCII case (OpenCV's older samples wrote
    /// `Camera_Matrix`).
    pub fn get_ignore_case(&self, key: &str) -> Option<&Node> {
        match &self.value {
            Value::Map(entries) => entries
                .iter()
                .find(|(k, _)| k.eq_ignore_ascii_case(key))
                .map(|(_, v)| v),
            _ => None,
        }
    }

    /// The mapping's entries, or `None` for other kinds.
    pub fn entries(&self) -> Option<&[(String, Node)]> {
        match &self.value {
            Value::Map(entries) => Some(entries),
            _ => None,
        }
    }

    /// The sequence's items, or `None` for other kinds.
    pub fn items(&self) -> Option<&[Node]> {
        match &self.value {
            Value::Seq(items) => Some(items),
            _ => None,
        }
    }

    /// The scalar's text, or `None` for other kinds.
    pub fn text(&self) -> Option<&str> {
        match &self.value {
            Value::Scalar { text, .. } => Some(text),
            _ => None,
        }
    }

    /// "a mapping", "a list", "the number 3", "the text \"x\"": for error messages.
    pub fn describe(&self) -> String {
        match &self.value {
            Value::Map(_) => "a mapping".into(),
            Value::Seq(items) => format!("a list of {}", items.len()),
            Value::Scalar { text, quoted } => {
                if text.is_empty() {
                    "nothing".into()
                } else if *quoted {
                    format!("the text \"{text}\"")
                } else {
                    format!("\"{text}\"")
                }
            }
        }
    }
}

enum Open {
    Seq(Vec<Node>, usize, Option<String>),
    Map(Vec<(String, Node)>, Option<String>, usize, Option<String>),
}

/// Parses the first document of `text` into a tree.
///
/// # Errors
/// The parser's message at its `file:line`, or an alias (`*name`), which calibration files never use.
pub(crate) fn parse(src: &Src<'_>, text: &str) -> Result<Node, CalibrationFileError> {
    // OpenCV writes `%YAML:1.0`; YAML 1.2 spells directives `%YAML 1.2`. Keep the line, drop the text.
    let cleaned;
    let text = if text.trim_start_matches('\u{feff}').starts_with("%YAML:") {
        let (first, rest) = text.split_once('\n').unwrap_or((text, ""));
        cleaned = format!(
            "#{}\n{rest}",
            first.trim_start_matches('\u{feff}').trim_start_matches('%')
        );
        cleaned.as_str()
    } else {
        text
    };
    let mut stack: Vec<Open> = Vec::new();
    let mut root: Option<Node> = None;
    for event in Parser::new_from_str(text) {
        let (event, span) = event.map_err(|e| {
            src.err(
                e.marker().line(),
                format!("not readable as YAML or JSON: {}", e.info()),
            )
        })?;
        let line = span.start.line();
        let node = match event {
            Event::StreamStart | Event::DocumentStart(_) | Event::Nothing => continue,
            Event::DocumentEnd | Event::StreamEnd => break,
            Event::Alias(_) => {
                return Err(src.err(
                    line,
                    "YAML aliases (*name) are not supported in calibration files",
                ));
            }
            Event::Scalar(value, style, _, tag) => Node {
                value: Value::Scalar {
                    text: value.into_owned(),
                    quoted: !matches!(style, ScalarStyle::Plain),
                },
                line,
                tag: tag.map(|t| t.suffix.clone()),
            },
            Event::SequenceStart(_, tag) => {
                stack.push(Open::Seq(Vec::new(), line, tag.map(|t| t.suffix.clone())));
                continue;
            }
            Event::MappingStart(_, tag) => {
                stack.push(Open::Map(Vec::new(), None, line, tag.map(|t| t.suffix.clone())));
                continue;
            }
            Event::SequenceEnd => match stack.pop() {
                Some(Open::Seq(items, line, tag)) => Node {
                    value: Value::Seq(items),
                    line,
                    tag,
                },
                _ => return Err(src.err(line, "unbalanced list")),
            },
            Event::MappingEnd => match stack.pop() {
                Some(Open::Map(entries, _, line, tag)) => Node {
                    value: Value::Map(entries),
                    line,
                    tag,
                },
                _ => return Err(src.err(line, "unbalanced mapping")),
            },
        };
        match stack.last_mut() {
            None => {
                if root.is_none() {
                    root = Some(node);
                }
            }
            Some(Open::Seq(items, ..)) => items.push(node),
            Some(Open::Map(entries, pending, ..)) => match pending.take() {
                None => match node.value {
                    Value::Scalar { text, .. } => *pending = Some(text),
                    _ => {
                        return Err(src.err(
                            node.line,
                            "a mapping key must be plain text, not a list or mapping",
                        ));
                    }
                },
                Some(key) => {
                    if entries.iter().any(|(k, _)| *k == key) {
                        return Err(src.err(node.line, format!("key \"{key}\" given twice")));
                    }
                    entries.push((key, node));
                }
            },
        }
        if root.is_some() && stack.is_empty() {
            break;
        }
    }
    root.ok_or_else(|| src.err(1, "the file holds no YAML or JSON document"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn src() -> Src<'static> {
        Src { file: "t.yaml" }
    }

    #[test]
    fn keeps_text_lines_and_tags() {
        let t = "%YAML:1.0\n---\nw: 640\nm: !!opencv-matrix\n   rows: 1\n   data: [ 1., 2.5e+02 ]\n";
        let root = parse(&src(), t).unwrap();
        assert_eq!(root.get("w").unwrap().text(), Some("640"));
        assert_eq!(root.get("w").unwrap().line, 3);
        let m = root.get("m").unwrap();
        assert_eq!(m.tag.as_deref(), Some("opencv-matrix"));
        let data = m.get("data").unwrap().items().unwrap();
        assert_eq!(data[0].text(), Some("1."));
        assert_eq!(data[1].text(), Some("2.5e+02"));
        assert_eq!(data[1].line, 6);
    }

    #[test]
    fn json_reads_as_flow_yaml() {
        let root = parse(&src(), "{\n  \"a\": [1, 2],\n  \"b\": \"x\"\n}\n").unwrap();
        assert_eq!(root.get("a").unwrap().items().unwrap().len(), 2);
        assert_eq!(root.get("b").unwrap().describe(), "the text \"x\"");
        assert_eq!(root.get("b").unwrap().line, 3);
    }

    #[test]
    fn syntax_errors_and_duplicates_name_the_line() {
        let e = parse(&src(), "a: 1\nb: [1, 2\nc: 3\n").unwrap_err();
        assert_eq!(e.file, "t.yaml");
        assert!(e.line.is_some());
        let e = parse(&src(), "a: 1\nb: 2\na: 3\n").unwrap_err();
        assert_eq!(e.line, Some(3), "{e}");
        assert!(e.message.contains("\"a\" given twice"), "{e}");
    }
}
