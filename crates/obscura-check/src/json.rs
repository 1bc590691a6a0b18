//! [`CheckReport::to_json`]: the report as one JSON object, written by hand (the format is small and
//! fixed, and the crate stays free of dependencies a plugin author would inherit).

use std::fmt::Write as _;

use obscura_sdk::PropertyValue;

use crate::report::value_text;
use crate::{Case, CheckReport, CheckResult, Status};

impl CheckReport {
    /// The same content as the [`Display`](std::fmt::Display) form, as one JSON object:
    ///
    /// `{"projection", "clean", "format": {"width", "height", "pixel_aspect"}, "screen_window": [l, r,
    /// b, t], "margin", "samples_per_pixel", "seed", "threads", "samples", "culled", "properties":
    /// {"k_DicingHint": "Perspective" | number | null, …}, "dicing_hint", "deep_metric", "checks": [{"check",
    /// "title", "status": "ok" | "failed" | "not_checked", "unit", "examined", "failures", "skipped",
    /// "notes": [..], "worst": null | {"screen": [x, y] | null, "lens", "time", "what", "expected",
    /// "got", "severity"}}]}`. Non-finite numbers are written as `null`.
    #[must_use]
    pub fn to_json(&self) -> String {
        let mut j = String::with_capacity(4096);
        j.push('{');
        self.json_sampling(&mut j);
        self.json_properties(&mut j);
        j.push_str(",\"checks\":[");
        for (i, c) in self.checks.iter().enumerate() {
            if i > 0 {
                j.push(',');
            }
            json_check(&mut j, c);
        }
        j.push_str("]}");
        j
    }

    /// From `"projection"` to `"culled"`: what was checked and how.
    fn json_sampling(&self, j: &mut String) {
        j.push_str("\"projection\":");
        json_str(j, &self.projection);
        let _ = write!(j, ",\"clean\":{}", self.is_clean());
        let _ = write!(
            j,
            ",\"format\":{{\"width\":{},\"height\":{},\"pixel_aspect\":{}}}",
            self.format.width,
            self.format.height,
            json_num(f64::from(self.format.pixel_aspect))
        );
        let w = self.screen_window;
        let _ = write!(
            j,
            ",\"screen_window\":[{},{},{},{}]",
            json_f32(w.left),
            json_f32(w.right),
            json_f32(w.bottom),
            json_f32(w.top)
        );
        let _ = write!(
            j,
            ",\"margin\":{},\"samples_per_pixel\":{},\"seed\":{},\"threads\":{},\"samples\":{},\"culled\":{}",
            self.margin, self.samples_per_pixel, self.seed, self.threads, self.samples, self.culled
        );
    }

    /// `"properties"`, `"dicing_hint"` and `"deep_metric"`.
    fn json_properties(&self, j: &mut String) {
        j.push_str(",\"properties\":{");
        for (i, (p, v)) in self.properties.iter().enumerate() {
            if i > 0 {
                j.push(',');
            }
            json_str(j, p.renderman_name());
            j.push(':');
            match v {
                None => j.push_str("null"),
                Some(PropertyValue::Float(x)) => j.push_str(&json_f32(*x)),
                Some(other) => json_str(j, &value_text(*other)),
            }
        }
        j.push('}');
        j.push_str(",\"dicing_hint\":");
        json_str(j, &format!("{:?}", self.dicing_hint));
        j.push_str(",\"deep_metric\":");
        json_str(j, &format!("{:?}", self.deep_metric));
    }
}

/// One element of `"checks"`.
fn json_check(j: &mut String, c: &CheckResult) {
    j.push_str("{\"check\":");
    json_str(j, c.kind.id());
    j.push_str(",\"title\":");
    json_str(j, c.kind.title());
    let status = match c.status() {
        Status::Ok => "ok",
        Status::Failed => "failed",
        Status::NotChecked => "not_checked",
    };
    let _ = write!(j, ",\"status\":\"{status}\",\"unit\":");
    json_str(j, c.kind.unit());
    let _ = write!(
        j,
        ",\"examined\":{},\"failures\":{},\"skipped\":{},\"notes\":[",
        c.examined, c.failures, c.skipped
    );
    for (k, n) in c.notes.iter().enumerate() {
        if k > 0 {
            j.push(',');
        }
        json_str(j, n);
    }
    j.push_str("],\"worst\":");
    match &c.worst {
        None => j.push_str("null"),
        Some(w) => json_case(j, w),
    }
    j.push('}');
}

/// A check's `"worst"` case.
fn json_case(j: &mut String, w: &Case) {
    j.push('{');
    match w.sample {
        None => j.push_str("\"screen\":null,\"lens\":null,\"time\":null"),
        Some(s) => {
            let _ = write!(
                j,
                "\"screen\":[{},{}],\"lens\":[{},{}],\"time\":{}",
                json_f32(s.screen.x),
                json_f32(s.screen.y),
                json_f32(s.lens.x),
                json_f32(s.lens.y),
                json_f32(s.time)
            );
        }
    }
    j.push_str(",\"what\":");
    json_str(j, &w.what);
    j.push_str(",\"expected\":");
    json_str(j, &w.expected);
    j.push_str(",\"got\":");
    json_str(j, &w.got);
    let _ = write!(j, ",\"severity\":{}}}", json_num(w.severity));
}

/// Appends `s` as a JSON string: quoted, with quotes, backslashes and control characters escaped.
pub(crate) fn json_str(out: &mut String, s: &str) {
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if (c as u32) < 0x20 => {
                let _ = write!(out, "\\u{:04x}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
}

/// A JSON number (Rust's `Display` never uses an exponent, so the text is valid JSON), or `null`.
pub(crate) fn json_num(x: f64) -> String {
    if x.is_finite() {
        format!("{x}")
    } else {
        "null".into()
    }
}

/// [`json_num`] for an `f32`.
pub(crate) fn json_f32(x: f32) -> String {
    if x.is_finite() {
        format!("{x}")
    } else {
        "null".into()
    }
}
