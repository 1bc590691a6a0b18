//! RenderMan's `Args/<Name>.args` files: the XML description of a plugin's parameters (defaults, help,
//! labels, ranges, options, widgets), read beside the library.
//!
//! ```xml
//! <args format="1.0">
//!   <param name="fov" label="Field of View" type="float" default="90" min="1" max="179" widget="default">
//!     <help>The angle across the shorter side.</help>
//!   </param>
//!   <page name="Stereo">
//!     <param name="eye" type="string" default="left" widget="popup">
//!       <hintdict name="options"><string name="Left" value="left"/><string name="Right" value="right"/></hintdict>
//!     </param>
//!   </page>
//! </args>
//! ```
//!
//! A default given here applies where the scene gives the parameter no value (the host hands it to the
//! plugin as given, as RenderMan's hosts write `.args` defaults into the scene); a parameter the
//! `.args` file and the plugin's table disagree on (missing from one, or of another type) is a warning
//! naming both; a file that cannot be read is a warning naming it, and the plugin loads from its table.

use std::path::{Path, PathBuf};

use obscura_sdk::{ParamDecl, ParamList, ParamType};

/// One `<param>` of an `.args` file.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ArgsParam {
    /// `name`.
    pub name: String,
    /// `type` as written (`float`, `int`, `string`, `color`, `point`, `vector`, `normal`, `matrix`).
    pub ty: String,
    /// `arraySize`, when the parameter is an array.
    pub array_size: Option<usize>,
    /// `default`, as written (values separated by spaces).
    pub default: Option<String>,
    /// `label`.
    pub label: Option<String>,
    /// `<help>` (or the `help` attribute), whitespace collapsed.
    pub help: Option<String>,
    /// `min` / `max` (also `slidermin` / `slidermax` when no hard limit is given).
    pub min: Option<String>,
    /// See `min`.
    pub max: Option<String>,
    /// `widget`.
    pub widget: Option<String>,
    /// `options="a|b"` or `<hintdict name="options">` entries, as (label, value).
    pub options: Vec<(String, String)>,
    /// The `<page>` the parameter is on.
    pub page: Option<String>,
    /// The line of the `<param>` element.
    pub line: u32,
}

/// A parsed `.args` file.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ArgsFile {
    /// The file.
    pub path: PathBuf,
    /// Its parameters, in file order.
    pub params: Vec<ArgsParam>,
}

/// `<dir of library>/Args/<Name>.args`, RenderMan's place for it.
#[must_use]
pub fn args_path(library: &Path, name: &str) -> PathBuf {
    library
        .parent()
        .unwrap_or_else(|| Path::new("."))
        .join("Args")
        .join(format!("{name}.args"))
}

/// Reads and parses an `.args` file.
///
/// # Errors
/// A message naming the file (and the line, for malformed XML or a `<param>` without a name).
pub fn read(path: &Path) -> Result<ArgsFile, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
    parse(path, &text)
}

/// Parses the text of an `.args` file (`path` names it in messages).
///
/// # Errors
/// See [`read`].
pub fn parse(path: &Path, text: &str) -> Result<ArgsFile, String> {
    let doc = roxmltree::Document::parse(text)
        .map_err(|e| format!("{}:{}: malformed XML: {e}", path.display(), e.pos().row))?;
    let root = doc.root_element();
    if root.tag_name().name() != "args" {
        return Err(format!(
            "{}:{}: the root element is <{}>, expected <args>",
            path.display(),
            doc.text_pos_at(root.range().start).row,
            root.tag_name().name()
        ));
    }
    let mut params = Vec::new();
    for node in root.descendants().filter(|n| n.has_tag_name("param")) {
        let line = doc.text_pos_at(node.range().start).row;
        let attr = |k: &str| node.attribute(k).map(str::to_string);
        let name =
            attr("name").ok_or_else(|| format!("{}:{line}: a <param> without a name", path.display()))?;
        let help = node
            .children()
            .find(|c| c.has_tag_name("help"))
            .and_then(|h| {
                let t: String = h
                    .descendants()
                    .filter(|d| d.is_text())
                    .filter_map(|d| d.text())
                    .collect();
                Some(t.split_whitespace().collect::<Vec<_>>().join(" ")).filter(|t| !t.is_empty())
            })
            .or_else(|| attr("help"));
        let mut options: Vec<(String, String)> = node
            .descendants()
            .filter(|d| d.has_tag_name("hintdict") && d.attribute("name") == Some("options"))
            .flat_map(|d| d.children().filter(|c| c.is_element()))
            .filter_map(|c| {
                let label = c.attribute("name")?.to_string();
                let value = c.attribute("value").map_or_else(|| label.clone(), str::to_string);
                Some((label, value))
            })
            .collect();
        if options.is_empty()
            && let Some(o) = node.attribute("options")
        {
            options = o
                .split('|')
                .filter(|s| !s.is_empty())
                .map(|s| match s.split_once(':') {
                    Some((l, v)) => (l.to_string(), v.to_string()),
                    None => (s.to_string(), s.to_string()),
                })
                .collect();
        }
        let page = node
            .ancestors()
            .find(|a| a.has_tag_name("page"))
            .and_then(|p| p.attribute("name"))
            .map(str::to_string);
        params.push(ArgsParam {
            name,
            ty: attr("type").unwrap_or_default(),
            array_size: node.attribute("arraySize").and_then(|s| s.parse().ok()),
            default: attr("default"),
            label: attr("label"),
            help,
            min: attr("min").or_else(|| attr("slidermin")),
            max: attr("max").or_else(|| attr("slidermax")),
            widget: attr("widget"),
            options,
            page,
            line,
        });
    }
    Ok(ArgsFile {
        path: path.to_path_buf(),
        params,
    })
}

/// The table type an `.args` type names.
fn param_type(ty: &str) -> Option<ParamType> {
    ParamType::from_rib_name(ty)
}

impl ArgsFile {
    /// Warnings for each parameter the file and the plugin's `table` disagree on, naming both.
    #[must_use]
    pub fn disagreements(&self, plugin: &str, library: &Path, table: &[ParamDecl]) -> Vec<String> {
        let mut out = Vec::new();
        let file = self.path.display();
        for p in &self.params {
            match table.iter().find(|d| d.name == p.name) {
                None => out.push(format!(
                    "{file}:{}: parameter \"{}\" is not in {plugin}'s parameter table ({}): the scene cannot give it",
                    p.line,
                    p.name,
                    library.display()
                )),
                Some(d) if param_type(&p.ty).is_some_and(|t| t != d.ty) || (!p.ty.is_empty() && param_type(&p.ty).is_none()) => {
                    out.push(format!(
                        "{file}:{}: parameter \"{}\" is a {} here but a {} in {plugin}'s parameter table ({}); the table wins",
                        p.line,
                        p.name,
                        p.ty,
                        d.ty,
                        library.display()
                    ));
                }
                Some(_) => {}
            }
        }
        for d in table {
            if !self.params.iter().any(|p| p.name == d.name) {
                out.push(format!(
                    "{file}: {plugin}'s parameter \"{}\" ({}) has no <param> here",
                    d.name,
                    library.display()
                ));
            }
        }
        out
    }

    /// The file's defaults for the parameters of `table` that `params` does not give, added to a copy
    /// of `params` (origin: the file and line). A default that does not read as its table type is
    /// left out with a warning, returned.
    #[must_use]
    pub fn with_defaults(&self, table: &[ParamDecl], params: &ParamList) -> (ParamList, Vec<String>) {
        let mut out = params.clone();
        let mut warnings = Vec::new();
        for d in table {
            if params.get(&d.name).is_some() {
                continue;
            }
            let Some(p) = self.params.iter().find(|p| p.name == d.name) else {
                continue;
            };
            let Some(default) = &p.default else { continue };
            let values: Vec<&str> = if d.ty == ParamType::String {
                vec![default.as_str()]
            } else {
                default
                    .split([' ', ',', '\t'])
                    .filter(|s| !s.is_empty())
                    .collect()
            };
            let decl = d.rib_declaration();
            let origin = format!("{}:{}", self.path.display(), p.line);
            if let Err(e) = out.push_text(&decl, &values, Some(origin.clone())) {
                warnings.push(format!(
                    "{origin}: the default of \"{}\" is left out: {e}",
                    d.name
                ));
            }
        }
        (out, warnings)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ARGS: &str = r#"<args format="1.0">
  <shaderType><tag value="projection"/></shaderType>
  <param name="fov" label="Field of View" type="float" default="120" min="1" max="179" widget="default">
    <help>
      The angle across the shorter side.
    </help>
  </param>
  <page name="Stereo">
    <param name="eye" type="string" default="right" widget="popup">
      <hintdict name="options"><string name="Left" value="left"/><string name="Right" value="right"/></hintdict>
    </param>
  </page>
  <param name="unknown" type="int" default="3"/>
</args>"#;

    #[test]
    fn an_args_file_reads_defaults_help_labels_ranges_options_and_pages() {
        let f = parse(Path::new("Args/X.args"), ARGS).unwrap();
        assert_eq!(f.params.len(), 3);
        let fov = &f.params[0];
        assert_eq!(
            (fov.name.as_str(), fov.default.as_deref(), fov.label.as_deref()),
            ("fov", Some("120"), Some("Field of View"))
        );
        assert_eq!(fov.help.as_deref(), Some("The angle across the shorter side."));
        assert_eq!(
            (fov.min.as_deref(), fov.max.as_deref(), fov.line),
            (Some("1"), Some("179"), 3)
        );
        let eye = &f.params[1];
        assert_eq!(
            eye.options,
            [
                ("Left".to_string(), "left".to_string()),
                ("Right".into(), "right".into())
            ]
        );
        assert_eq!(
            (eye.page.as_deref(), eye.widget.as_deref()),
            (Some("Stereo"), Some("popup"))
        );
    }

    #[test]
    fn malformed_args_name_the_file_and_line() {
        let e = parse(
            Path::new("Args/X.args"),
            "<args>\n<param name=\"a\" type=\"float\">\n</args>",
        )
        .unwrap_err();
        assert!(e.starts_with("Args/X.args:3: malformed XML"), "{e}");
        let e = parse(
            Path::new("Args/X.args"),
            "<args>\n  <param type=\"float\"/>\n</args>",
        )
        .unwrap_err();
        assert_eq!(e, "Args/X.args:2: a <param> without a name");
        let e = parse(Path::new("Args/X.args"), "<shader/>").unwrap_err();
        assert!(e.contains("expected <args>"), "{e}");
    }

    #[test]
    fn defaults_fill_what_the_scene_leaves_and_disagreements_name_both() {
        let f = parse(Path::new("Args/X.args"), ARGS).unwrap();
        let table = vec![
            ParamDecl::float("fov", 0.0),
            ParamDecl::string("eye", ""),
            ParamDecl::int("lonely", 0),
        ];
        let mut given = ParamList::new();
        given.push_text("string eye", &["left"], None).unwrap();
        let (list, warnings) = f.with_defaults(&table, &given);
        assert!(warnings.is_empty(), "{warnings:?}");
        assert_eq!(
            list.get("fov").unwrap().value,
            obscura_sdk::ParamValue::Floats(vec![120.0])
        );
        assert_eq!(list.get("fov").unwrap().origin.as_deref(), Some("Args/X.args:3"));
        assert_eq!(
            list.get("eye").unwrap().value,
            obscura_sdk::ParamValue::Strings(vec!["left".into()])
        );
        let w = f.disagreements("X", Path::new("/p/X.so"), &table);
        assert_eq!(
            w,
            [
                "Args/X.args:13: parameter \"unknown\" is not in X's parameter table (/p/X.so): the scene cannot give it",
                "Args/X.args: X's parameter \"lonely\" (/p/X.so) has no <param> here",
            ]
        );
    }
}
