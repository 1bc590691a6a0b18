//! Which generation of RenderMan's projection interface a source is written for, from the
//! signatures it uses.

use std::fmt;
use std::path::Path;

/// A generation of RenderMan's projection interface.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Generation {
    /// RenderMan 19–21: one class deriving from `RixProjection` is the plugin
    /// (`RIX_PROJECTIONCREATE`, `Init(RixContext&, char const*)`, `RenderBegin(…, RixProjectionEnvironment&, …)`).
    G1,
    /// RenderMan 22: `RixProjectionFactory::CreateProjection(RixContext&, RixProjectionEnvironment&, …)`,
    /// the deep metric written into `env.deepMetric`.
    G2,
    /// RenderMan 23–27: `CreateProjection(RixContext&, RtUString const, RixParameterList const*)` and
    /// the projection's `RenderBegin(…, RixProjectionEnvironment const&, …)`.
    G3,
}

impl Generation {
    /// The generation of RenderMan release `version` (19–27), or `None` outside that range.
    #[must_use]
    pub fn of_version(version: u32) -> Option<Generation> {
        match version {
            19..=21 => Some(Generation::G1),
            22 => Some(Generation::G2),
            23..=27 => Some(Generation::G3),
            _ => None,
        }
    }

    /// The release `obscura build-plugin` selects for a detected generation (its newest).
    #[must_use]
    pub fn default_version(self) -> u32 {
        match self {
            Generation::G1 => 21,
            Generation::G2 => 22,
            Generation::G3 => 27,
        }
    }

    /// The releases, as people say them: "RenderMan 19-21".
    #[must_use]
    pub fn releases(self) -> &'static str {
        match self {
            Generation::G1 => "RenderMan 19-21",
            Generation::G2 => "RenderMan 22",
            Generation::G3 => "RenderMan 23-27",
        }
    }
}

impl fmt::Display for Generation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.releases())
    }
}

/// What [`detect`] found: the generation, and the line that shows it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Detected {
    /// The generation the source is written for.
    pub generation: Generation,
    /// Where and why: `fisheye.cpp:42: CreateProjection takes a RixProjectionEnvironment&`.
    pub evidence: String,
}

/// The generation of the first of `sources` that shows one (files that cannot be read are skipped).
#[must_use]
pub fn detect(sources: &[&Path]) -> Option<Detected> {
    sources.iter().find_map(|p| {
        let text = std::fs::read_to_string(p).ok()?;
        let name = p
            .file_name()
            .map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned());
        detect_text(&name, &text)
    })
}

/// The generation `text` (the file `name`) is written for. Each generation has signatures only it
/// uses; comments and string literals are ignored, and the first sign in the file decides, checked in
/// the order: RenderMan 22's environment in `CreateProjection`, RenderMan 19–21's entry macro or
/// `char const*` plugin path or non-const environment in `RenderBegin`, then RenderMan 23–27's const
/// environment, `k_DeepMetric` or factory entry macro.
#[must_use]
pub fn detect_text(name: &str, text: &str) -> Option<Detected> {
    let code = strip_comments_and_strings(text);
    // Whole declarations can span lines: search in the text with newlines kept for line numbers, but
    // look at each call's parenthesised argument list as one string.
    let line_of = |pos: usize| code[..pos].matches('\n').count() + 1;
    let found = |g: Generation, pos: usize, why: &str| Detected {
        generation: g,
        evidence: format!("{name}:{}: {why}", line_of(pos)),
    };
    for (pos, args) in calls(&code, "CreateProjection") {
        if args.contains("RixProjectionEnvironment") {
            return Some(found(
                Generation::G2,
                pos,
                "CreateProjection takes a RixProjectionEnvironment&",
            ));
        }
    }
    if let Some(pos) = env_deep_metric_write(&code) {
        return Some(found(
            Generation::G2,
            pos,
            "the environment's deepMetric is written",
        ));
    }
    if let Some(pos) = find_word(&code, "RIX_PROJECTIONCREATE") {
        return Some(found(
            Generation::G1,
            pos,
            "RIX_PROJECTIONCREATE (a self-contained RixProjection)",
        ));
    }
    for (pos, args) in calls(&code, "Init") {
        let a = args.replace(' ', "");
        if a.contains("RixContext") && (a.contains("charconst*") || a.contains("constchar*")) {
            return Some(found(
                Generation::G1,
                pos,
                "Init takes the plugin path as char const*",
            ));
        }
    }
    for (pos, args) in calls(&code, "RenderBegin") {
        let a = args.replace(' ', "");
        if a.contains("RixProjectionEnvironment&")
            && !a.contains("RixProjectionEnvironmentconst&")
            && !a.contains("constRixProjectionEnvironment&")
        {
            return Some(found(
                Generation::G1,
                pos,
                "RenderBegin takes a non-const RixProjectionEnvironment&",
            ));
        }
        if a.contains("RixProjectionEnvironment") {
            return Some(found(
                Generation::G3,
                pos,
                "RenderBegin takes a RixProjectionEnvironment const&",
            ));
        }
    }
    if let Some(pos) = find_word(&code, "k_DeepMetric") {
        return Some(found(Generation::G3, pos, "GetProperty answers k_DeepMetric"));
    }
    for (pos, args) in calls(&code, "CreateProjection") {
        if args.contains("RixContext") {
            return Some(found(
                Generation::G3,
                pos,
                "CreateProjection takes no environment",
            ));
        }
    }
    if let Some(pos) = find_word(&code, "RIX_PROJECTIONFACTORYCREATE") {
        return Some(found(
            Generation::G3,
            pos,
            "RIX_PROJECTIONFACTORYCREATE (a factory)",
        ));
    }
    None
}

/// Where `code` writes the environment's deep metric (RenderMan 22): `RixProjectionEnvironment::k_…`
/// or `.deepMetric =` (a member of the plugin's own named `deepMetric` is not one).
fn env_deep_metric_write(code: &str) -> Option<usize> {
    if let Some(pos) = code.find("RixProjectionEnvironment::k_") {
        return Some(pos);
    }
    let mut from = 0;
    while let Some(rel) = code[from..].find(".deepMetric") {
        let pos = from + rel;
        let rest = code[pos + ".deepMetric".len()..].trim_start();
        if rest.starts_with('=') && !rest.starts_with("==") {
            return Some(pos);
        }
        from = pos + 1;
    }
    None
}

/// Every `name(…)` in `code`: the name's byte position and the text between its parentheses.
fn calls<'a>(code: &'a str, name: &str) -> Vec<(usize, &'a str)> {
    let mut out = Vec::new();
    let mut from = 0;
    while let Some(rel) = find_word(&code[from..], name) {
        let pos = from + rel;
        let rest = &code[pos + name.len()..];
        let trimmed = rest.trim_start();
        if let Some(inner) = trimmed.strip_prefix('(') {
            let mut depth = 1;
            let mut end = inner.len();
            for (i, c) in inner.char_indices() {
                match c {
                    '(' => depth += 1,
                    ')' => {
                        depth -= 1;
                        if depth == 0 {
                            end = i;
                            break;
                        }
                    }
                    _ => {}
                }
            }
            out.push((pos, &inner[..end]));
        }
        from = pos + name.len();
    }
    out
}

/// The byte position of `word` in `code` as a whole identifier.
fn find_word(code: &str, word: &str) -> Option<usize> {
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let mut from = 0;
    while let Some(rel) = code[from..].find(word) {
        let pos = from + rel;
        let before = code[..pos].chars().next_back();
        let after = code[pos + word.len()..].chars().next();
        if !before.is_some_and(ident) && !after.is_some_and(ident) {
            return Some(pos);
        }
        from = pos + word.len();
    }
    None
}

/// `text` with comments and the contents of string and character literals blanked (newlines kept).
fn strip_comments_and_strings(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '/' if chars.peek() == Some(&'/') => {
                for c in chars.by_ref() {
                    if c == '\n' {
                        out.push('\n');
                        break;
                    }
                    out.push(' ');
                }
            }
            '/' if chars.peek() == Some(&'*') => {
                chars.next();
                out.push_str("  ");
                let mut prev = ' ';
                for c in chars.by_ref() {
                    out.push(if c == '\n' { '\n' } else { ' ' });
                    if prev == '*' && c == '/' {
                        break;
                    }
                    prev = c;
                }
            }
            '"' | '\'' => {
                out.push(c);
                let mut escaped = false;
                for d in chars.by_ref() {
                    if d == '\n' {
                        out.push('\n');
                        break;
                    }
                    if !escaped && d == c {
                        out.push(c);
                        break;
                    }
                    escaped = !escaped && d == '\\';
                    out.push(' ');
                }
            }
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_generation_is_told_by_its_own_signature() {
        let g2 = "RixProjection* CreateProjection(RixContext& ctx,\n RixProjectionEnvironment& env, RtUString const h, RixParameterList const* p) override";
        assert_eq!(detect_text("a.cpp", g2).unwrap().generation, Generation::G2);
        let g1 = "class P : public RixProjection {\n int Init(RixContext& ctx, char const* pluginPath) { return 0; }\n};";
        let d = detect_text("p.cpp", g1).unwrap();
        assert_eq!(
            (d.generation, d.evidence.as_str()),
            (
                Generation::G1,
                "p.cpp:2: Init takes the plugin path as char const*"
            )
        );
        let g3 = "void RenderBegin(RixContext& ctx, RixProjectionEnvironment const& env, RixParameterList const* p) override";
        assert_eq!(detect_text("b.cpp", g3).unwrap().generation, Generation::G3);
        let g1b = "virtual void RenderBegin(RixContext &ctx, RixProjectionEnvironment &env, RixParameterList const *p)";
        assert_eq!(detect_text("c.cpp", g1b).unwrap().generation, Generation::G1);
        // A comment or a string naming another generation's signature changes nothing.
        let commented =
            format!("// RIX_PROJECTIONCREATE was RenderMan 21's\nconst char* s = \"deepMetric\";\n{g3}");
        assert_eq!(
            detect_text("d.cpp", &commented).unwrap().generation,
            Generation::G3
        );
        assert_eq!(detect_text("e.cpp", "int main() { return 0; }"), None);
        // A projection's own member called deepMetric is RenderMan 23-27's GetProperty idiom.
        let member = format!("DeepMetric const deepMetric;\n: deepMetric(k_rayLength)\n{g3}");
        assert_eq!(detect_text("f.cpp", &member).unwrap().generation, Generation::G3);
        let g2b = "env.deepMetric = RixProjectionEnvironment::k_rayLength;";
        assert_eq!(detect_text("g.cpp", g2b).unwrap().generation, Generation::G2);
    }

    #[test]
    fn versions_map_to_generations() {
        assert_eq!(Generation::of_version(21), Some(Generation::G1));
        assert_eq!(Generation::of_version(22), Some(Generation::G2));
        assert_eq!(Generation::of_version(25), Some(Generation::G3));
        assert_eq!(Generation::of_version(28), None);
        for g in [Generation::G1, Generation::G2, Generation::G3] {
            assert_eq!(Generation::of_version(g.default_version()), Some(g));
        }
    }
}
