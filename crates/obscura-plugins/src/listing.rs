//! `obscura plugins`: the projections a registry knows and their parameter tables, as text.

use obscura_host::Registry;
use obscura_sdk::{ParamDecl, ParamValue, PluginError, ProjectionFactory};

/// The listing of one projection: its name and summary, then one line per parameter with its RIB
/// declaration, default, allowed values and documentation.
#[must_use]
pub fn describe(factory: &dyn ProjectionFactory) -> String {
    let mut out = format!("{}\n    {}\n", factory.name(), factory.summary());
    let table = factory.param_table();
    if table.is_empty() {
        out.push_str("    (no parameters)\n");
    }
    let rows: Vec<(String, String, String, &str)> = table
        .iter()
        .map(|d| {
            (
                d.rib_declaration(),
                default_text(d),
                allowed_text(d),
                d.doc.as_ref(),
            )
        })
        .collect();
    let w0 = rows.iter().map(|r| r.0.len()).max().unwrap_or(0);
    let w1 = rows.iter().map(|r| r.1.chars().count()).max().unwrap_or(0);
    let w2 = rows.iter().map(|r| r.2.chars().count()).max().unwrap_or(0);
    for (decl, default, allowed, doc) in rows {
        out.push_str(&format!(
            "    \"{decl}\"{:p0$} {default}{:p1$}  {allowed}{:p2$}  {doc}\n",
            "",
            "",
            "",
            p0 = w0 - decl.len(),
            p1 = w1 - default.chars().count(),
            p2 = w2 - allowed.chars().count(),
        ));
    }
    for line in factory.listing_notes() {
        out.push_str(&format!("    {line}\n"));
    }
    out
}

fn default_text(d: &ParamDecl) -> String {
    match &d.default {
        ParamValue::Strings(v) if v.len() == 1 => format!("[\"{}\"]", v[0]),
        v => v.to_string(),
    }
}

fn allowed_text(d: &ParamDecl) -> String {
    if let Some(r) = d.range {
        r.to_string()
    } else if !d.choices.is_empty() {
        d.choices.join("|")
    } else {
        String::new()
    }
}

/// What `Args/<name>.args` beside the library at `path` says of each parameter (default, label,
/// range, options, widget, page, help), or nothing when there is no such file or it is malformed.
fn args_text(path: &std::path::Path, name: &str) -> String {
    let file = crate::rman::args::args_path(path, name);
    let Ok(args) = crate::rman::args::read(&file) else {
        return String::new();
    };
    let mut out = format!("    {}:\n", file.display());
    for p in &args.params {
        let mut parts = Vec::new();
        if let Some(d) = &p.default {
            parts.push(format!("default {d}"));
        }
        if let Some(l) = &p.label {
            parts.push(format!("label \"{l}\""));
        }
        match (&p.min, &p.max) {
            (Some(a), Some(b)) => parts.push(format!("range [{a}, {b}]")),
            (Some(a), None) => parts.push(format!("min {a}")),
            (None, Some(b)) => parts.push(format!("max {b}")),
            (None, None) => {}
        }
        if !p.options.is_empty() {
            let o: Vec<String> = p
                .options
                .iter()
                .map(|(l, v)| if l == v { v.clone() } else { format!("{l}={v}") })
                .collect();
            parts.push(format!("options {}", o.join("|")));
        }
        if let Some(w) = &p.widget {
            parts.push(format!("widget {w}"));
        }
        if let Some(pg) = &p.page {
            parts.push(format!("page \"{pg}\""));
        }
        out.push_str(&format!("      {} {}: {}\n", p.ty, p.name, parts.join(", ")));
        if let Some(h) = &p.help {
            out.push_str(&format!("        {h}\n"));
        }
    }
    out
}

/// Every projection in `registry`, or only `name`.
///
/// # Errors
/// [`PluginError::Unknown`] when `name` is not registered.
pub fn list(registry: &Registry, name: Option<&str>) -> Result<String, PluginError> {
    let entry = |n: &str| -> Result<String, PluginError> {
        let mut text = describe(registry.find(n)?);
        // A plugin says where it came from, under its summary.
        if let Some(path) = registry.path(n).filter(|p| !p.is_empty()) {
            let at = text.find('\n').map_or(text.len(), |i| i + 1);
            let at = text[at..].find('\n').map_or(text.len(), |i| at + i + 1);
            text.insert_str(at, &format!("    plugin: {path}\n"));
            text.push_str(&args_text(std::path::Path::new(path), n));
        }
        Ok(text)
    };
    match name {
        Some(n) => entry(n),
        None => Ok(registry
            .names()
            .iter()
            .map(|n| entry(n))
            .collect::<Result<Vec<_>, _>>()?
            .join("\n")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::builtin_registry;

    #[test]
    fn perspective_listing_shows_declarations_defaults_ranges_and_docs() {
        let text = list(&builtin_registry(), Some("PxrPerspective")).unwrap();
        assert!(text.starts_with("PxrPerspective\n"), "{text}");
        let fov = text.lines().find(|l| l.contains("\"float fov\"")).unwrap();
        assert!(
            fov.contains("[90]") && fov.contains("[0.001, 180)") && fov.contains("field of view"),
            "{fov}"
        );
        let fstop = text.lines().find(|l| l.contains("\"float fStop\"")).unwrap();
        assert!(fstop.contains("[inf]") && fstop.contains("[0, ∞]"), "{fstop}");
    }

    #[test]
    fn full_listing_has_every_builtin_and_unknown_names_are_errors() {
        let text = list(&builtin_registry(), None).unwrap();
        assert!(text.contains("PxrOrthographic\n") && text.contains("PxrPerspective\n"));
        let err = list(&builtin_registry(), Some("Nope")).unwrap_err().to_string();
        assert!(
            err.contains("known projections: CalibratedCamera, ") && err.contains(", PxrOrthographic, "),
            "{err}"
        );
    }
}
