//! The documents keep their promises: every test `docs/decisions.md` names exists, and the build line
//! `docs/plugin-abi.md` gives for the C example works as written.
//!
//! **Which names are tests.** In every table of `docs/decisions.md` whose header has a column titled
//! "held by" or "test" (case-insensitive), each backticked span of that column that is a bare Rust
//! identifier (`[A-Za-z_][A-Za-z0-9_]*`) names a test. Other spans in that column are files or
//! commands (`driver.rs`, `docs/sampling.png`, `obscura check`), not test names. Cells are split at
//! every `|` not escaped as `\|` (GitHub's rule, which ignores code spans), and the column is counted
//! from the *end* of each row: a stray `|` in an earlier column (`| |D| − 1 |`) then moves no later
//! column. A test exists when some `.rs` file under `crates/` or `examples/` holds `fn NAME(`, or
//! some `.py` file there (the Python package's pytest tests) holds `def NAME(`.

use std::path::{Path, PathBuf};
use std::process::Command;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The cells of one table row, split at unescaped pipes, without the outer empty cells.
fn cells(row: &str) -> Vec<String> {
    let mut out = vec![String::new()];
    let mut chars = row.trim().chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '\\' if chars.peek() == Some(&'|') => {
                out.last_mut().unwrap().push('|');
                chars.next();
            }
            '|' => out.push(String::new()),
            _ => out.last_mut().unwrap().push(c),
        }
    }
    if out.first().is_some_and(|c| c.trim().is_empty()) {
        out.remove(0);
    }
    if out.last().is_some_and(|c| c.trim().is_empty()) {
        out.pop();
    }
    out
}

fn is_delimiter_row(row: &str) -> bool {
    let c = cells(row);
    !c.is_empty()
        && c.iter()
            .all(|c| !c.trim().is_empty() && c.trim().chars().all(|ch| matches!(ch, '-' | ':')))
}

fn is_identifier(s: &str) -> bool {
    let mut chars = s.chars();
    chars.next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// The backticked spans of a cell.
fn code_spans(cell: &str) -> Vec<&str> {
    cell.split('`').skip(1).step_by(2).collect()
}

/// Every test name the document's tables give in their test column (see the module documentation),
/// with the line it is on, in order.
fn test_names(markdown: &str) -> Vec<(usize, String)> {
    let lines: Vec<&str> = markdown.lines().collect();
    let mut names = Vec::new();
    let mut i = 0;
    while i + 1 < lines.len() {
        let header = lines[i];
        if !(header.trim_start().starts_with('|') && is_delimiter_row(lines[i + 1])) {
            i += 1;
            continue;
        }
        let titles = cells(header);
        let column = titles.iter().position(|t| {
            let t = t.trim().to_ascii_lowercase();
            t == "held by" || t == "test" || t == "tests"
        });
        i += 2;
        while i < lines.len() && lines[i].trim_start().starts_with('|') {
            if let Some(col) = column {
                let row = cells(lines[i]);
                assert!(
                    row.len() >= titles.len(),
                    "decisions.md:{}: {} cells, but the table's header has {}",
                    i + 1,
                    row.len(),
                    titles.len()
                );
                let cell = &row[row.len() - (titles.len() - col)];
                for span in code_spans(cell) {
                    if is_identifier(span) {
                        names.push((i + 1, span.to_string()));
                    }
                }
            }
            i += 1;
        }
    }
    names
}

/// Every `.rs` and `.py` file under `dir`, skipping build output and hidden directories.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.filter_map(Result::ok) {
        let path = entry.path();
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if path.is_dir() {
            if !name.starts_with('.') && name != "target" {
                rust_files(&path, out);
            }
        } else if name.ends_with(".rs") || name.ends_with(".py") {
            out.push(path);
        }
    }
}

#[test]
fn the_test_column_is_read_from_the_header_and_counted_from_the_end() {
    let doc = "\
| topic | decision | held by |
|---|---|---|
| tolerance | `| |D| − 1 | ≤ 10⁻³` and |x| | `first_test`, `driver.rs` tests |
| files | escaped \\| pipe | `second_test` in `obscura check`; `docs/a.png` |

| topic | why |
|---|---|
| other | `not_a_test` |
";
    let names: Vec<String> = test_names(doc).into_iter().map(|(_, n)| n).collect();
    assert_eq!(names, ["first_test", "second_test"]);
}

#[test]
fn every_test_named_in_decisions_exists() {
    let root = workspace();
    let doc = read(&root.join("docs/decisions.md"));
    let names = test_names(&doc);
    // The document names dozens of tests: finding few means the table's shape changed, not that
    // every test is there.
    assert!(
        names.len() >= 40,
        "only {} test names found in docs/decisions.md; did its tables lose their \"held by\" column?",
        names.len()
    );
    let mut files = Vec::new();
    rust_files(&root.join("crates"), &mut files);
    rust_files(&root.join("examples"), &mut files);
    let sources: Vec<String> = files.iter().map(|f| read(f)).collect();
    let missing: Vec<String> = names
        .iter()
        .filter(|(_, name)| {
            let (rust, python) = (format!("fn {name}("), format!("def {name}("));
            !sources.iter().any(|s| s.contains(&rust) || s.contains(&python))
        })
        .map(|(line, name)| format!("  docs/decisions.md:{line}: {name}"))
        .collect();
    assert!(
        missing.is_empty(),
        "tests named in docs/decisions.md but found as `fn NAME(` (`def NAME(` in Python) in no \
         file under crates/ or examples/ (renamed? update the document):\n{}",
        missing.join("\n")
    );
}

/// The marker in `docs/plugin-abi.md` that the next fenced block holds the C example's build line.
const BUILD_MARKER: &str = "<!-- c-example-build";

/// The `cc` command lines of the fenced block after [`BUILD_MARKER`], split into words.
fn documented_build_commands(markdown: &str) -> Vec<Vec<String>> {
    let start = markdown
        .find(BUILD_MARKER)
        .expect("docs/plugin-abi.md marks the C example's build block with `<!-- c-example-build`");
    let after = &markdown[start..];
    let open = after.find("```").expect("a fenced block after the build marker");
    let body = &after[open + 3..];
    let body = &body[body.find('\n').map_or(body.len(), |n| n + 1)..];
    let end = body.find("```").expect("the build block is closed");
    body[..end]
        .lines()
        .map(str::trim)
        .filter(|l| l.starts_with("cc "))
        .map(|l| {
            assert!(
                !l.contains(['"', '\'', '\\', '$', '`']),
                "the build line must be plain words for this test to run it: {l}"
            );
            l.split_whitespace().map(str::to_string).collect()
        })
        .collect()
}

fn lib_name(name: &str) -> String {
    format!("{name}.{}", std::env::consts::DLL_EXTENSION)
}

#[test]
fn plugin_abi_build_line_works_from_the_root() {
    let root = workspace();
    let commands = documented_build_commands(&read(&root.join("docs/plugin-abi.md")));
    assert!(
        !commands.is_empty(),
        "no `cc` line in docs/plugin-abi.md's build block"
    );
    let has_cc = Command::new("cc")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !has_cc {
        assert!(
            std::env::var_os("OBSCURA_REQUIRE_CC").is_none(),
            "a C compiler `cc` is required here (OBSCURA_REQUIRE_CC is set) but missing"
        );
        eprintln!("skipping: no C compiler `cc` on PATH");
        return;
    }
    let out_dir = tempfile::tempdir().unwrap();
    for words in commands {
        // The documented output file, moved into the temporary directory under this platform's
        // library name (the document's `CFisheye.so` is `CFisheye.dylib` on macOS).
        let o = words
            .iter()
            .position(|w| w == "-o")
            .unwrap_or_else(|| panic!("the build line names its output with -o: {}", words.join(" ")));
        let documented = Path::new(&words[o + 1]);
        let stem = documented
            .file_stem()
            .and_then(|s| s.to_str())
            .expect("an output file name");
        let output = out_dir.path().join(lib_name(stem));
        let mut args = words[1..].to_vec();
        args[o] = output.to_string_lossy().into_owned();
        let run = Command::new("cc")
            .args(&args)
            .current_dir(&root)
            .output()
            .expect("cc runs");
        assert!(
            run.status.success(),
            "the documented build line failed from the repository root:\n  {}\n{}",
            words.join(" "),
            String::from_utf8_lossy(&run.stderr)
        );
        assert!(output.is_file(), "{} was not written", output.display());
        // Loadable: `obscura plugins` opens it from the plugin path and lists it by name.
        let listed = Command::new(env!("CARGO_BIN_EXE_obscura"))
            .args(["plugins", "--names", "--plugin-path"])
            .arg(out_dir.path())
            .env_remove("OBSCURA_PLUGIN_PATH")
            .output()
            .expect("the obscura binary runs");
        let names = String::from_utf8_lossy(&listed.stdout);
        assert!(
            listed.status.success() && names.lines().any(|l| l == stem),
            "obscura plugins does not list {stem} from {}:\n{names}{}",
            out_dir.path().display(),
            String::from_utf8_lossy(&listed.stderr)
        );
    }
}
