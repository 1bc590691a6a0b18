//! The tokenizer: comments, strings, numbers, arrays, line numbers, and what it refuses.

use proptest::prelude::*;

use super::*;
use crate::rib::lex::{Num, Value, lex};

fn num(value: f64, int: Option<i32>) -> Num {
    Num { value, int }
}

#[test]
fn lexer_reads_comments_strings_escapes_numbers_and_arrays() {
    let text = "# heading\nFoo \"a\\\"b\\\\c\\nd\" -1.5e2 .5 +3 42 [1 2.0] [\"x\" \"y\"] [] # tail\nBar";
    let cmds = lex(text).unwrap();
    assert_eq!(cmds.len(), 2);
    assert_eq!((cmds[0].name.as_str(), cmds[0].line), ("Foo", 2));
    assert_eq!(
        cmds[0].args,
        vec![
            Value::Str("a\"b\\c\nd".into()),
            Value::Num(num(-150.0, None)),
            Value::Num(num(0.5, None)),
            Value::Num(num(3.0, Some(3))),
            Value::Num(num(42.0, Some(42))),
            Value::Nums(vec![num(1.0, Some(1)), num(2.0, None)]),
            Value::Strs(vec!["x".into(), "y".into()]),
            Value::Nums(vec![]),
        ]
    );
    assert_eq!(
        (cmds[1].name.as_str(), cmds[1].line, cmds[1].args.len()),
        ("Bar", 3, 0)
    );
}

#[test]
fn lexer_counts_lines_inside_strings_and_arrays() {
    let cmds = lex("A \"x\ny\" [1\n2]\nB").unwrap();
    assert_eq!(cmds[0].line, 1);
    assert_eq!(cmds[1].line, 4);
}

#[test]
fn unterminated_string_names_the_line_it_started() {
    let msg = fail("Format 64 64 1\nDisplay \"a.exr\n\n\nWorldBegin\n");
    assert_eq!(msg, "t.rib:2: unterminated string: the closing '\"' is missing");
}

#[test]
fn unterminated_array_names_the_line_it_started() {
    let msg = fail("WorldBegin\nPolygon \"P\" [0 0 0\n1 0 0\nSphere 1 -1 1 360\n");
    assert_eq!(
        msg,
        "t.rib:2: unterminated array: no ']' before the next request (Sphere)"
    );
    let msg = fail("WorldBegin\n\nPolygon \"P\" [0 0 0\n1 0 0\n");
    assert_eq!(msg, "t.rib:3: unterminated array: the closing ']' is missing");
}

#[test]
fn malformed_numbers_and_stray_values_are_errors_with_lines() {
    assert_eq!(
        fail("\nTranslate 1e 0 0"),
        "t.rib:2: cannot read the number \"1e\""
    );
    assert_eq!(
        fail("3 Format 1 1 1"),
        "t.rib:1: expected a request name, got the number 3"
    );
    assert_eq!(fail("Foo ]"), "t.rib:1: ']' without a matching '['");
    assert_eq!(
        fail("Foo [1 \"a\"]"),
        "t.rib:1: an array mixes numbers and strings"
    );
}

proptest! {
    #![proptest_config(no_persistence())]

    #[test]
    fn lexer_never_panics(text in ".*") {
        let _ = lex(&text);
    }
}
