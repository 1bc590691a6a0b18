//! `Option "searchpath"`: where a relative texture or archive name is looked for.
//!
//! ```text
//! Option "searchpath" "string texture" ["textures:../shared/maps:&"]
//! ```
//!
//! As RenderMan reads it: directories separated by `:` (or `;`), `&` standing for the path as it was
//! before this request and `@` for the default (which is empty here). Relative directories are taken
//! from the directory of the RIB file that sets them. A relative texture (`texture`) or
//! `ReadArchive` name (`archive`) is looked for in each directory in order, then beside the RIB file
//! that names it; an absolute name is used as it is. `rixplugin` directories are where projection
//! plugins are looked for ([`crate::Scene::plugin_path`]). The other kinds (`shader`, `procedural`,
//! `display`, `resource`) are noted once and ignored: the renderer runs no shaders or programs.

use std::path::{Path, PathBuf};

use super::lex::Value;
use super::request::{Req, get_string};
use super::{Reader, RibError};

/// The search paths the reader uses.
#[derive(Debug, Clone, Default, PartialEq)]
pub(super) struct SearchPaths {
    /// `Option "searchpath" "texture"`.
    pub(super) texture: Vec<PathBuf>,
    /// `Option "searchpath" "archive"`.
    pub(super) archive: Vec<PathBuf>,
}

/// Which search path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Kind {
    /// Textures.
    Texture,
    /// `ReadArchive` files.
    Archive,
}

impl SearchPaths {
    fn dirs(&self, kind: Kind) -> &[PathBuf] {
        match kind {
            Kind::Texture => &self.texture,
            Kind::Archive => &self.archive,
        }
    }
}

/// The kinds `Option "searchpath"` takes, declared for names written bare.
const KINDS: [&str; 7] = [
    "string texture",
    "string rixplugin",
    "string shader",
    "string archive",
    "string procedural",
    "string display",
    "string resource",
];

/// The directories of a search path `value`, relative ones taken from `base`; `&` is `previous`.
fn parse_path(value: &str, base: &Path, previous: &[PathBuf]) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in value.split([':', ';']).filter(|e| !e.is_empty()) {
        match entry {
            "&" => out.extend(previous.iter().cloned()),
            "@" => {}
            // `.` components dropped, so messages name `dir/f.tif`, not `dir/./f.tif`.
            dir => out.push(
                base.join(dir)
                    .components()
                    .filter(|c| *c != std::path::Component::CurDir)
                    .collect(),
            ),
        }
    }
    out
}

impl Reader {
    /// `Option "searchpath" …`.
    pub(super) fn search_path(&mut self, r: &Req<'_>, rest: &[Value]) -> Result<(), RibError> {
        let list = self.params(r, rest, &KINDS, false)?;
        for decl in KINDS {
            let kind = &decl["string ".len()..];
            let Some(value) = get_string(&list, kind) else {
                continue;
            };
            match kind {
                "texture" => self.search.texture = parse_path(value, r.base, &self.search.texture),
                "archive" => self.search.archive = parse_path(value, r.base, &self.search.archive),
                "rixplugin" => self.scene.plugin_path = parse_path(value, r.base, &self.scene.plugin_path),
                _ => self.warn_once(
                    r,
                    &format!("searchpath {kind}"),
                    format!("Option \"searchpath\" \"{kind}\" is ignored (no shaders or programs are run)"),
                ),
            }
        }
        Ok(())
    }

    /// The file `name` (a texture or an archive, by `kind`) named at `r` refers to, when one exists
    /// (see the module documentation for the order).
    pub(super) fn find_file(&self, kind: Kind, r: &Req<'_>, name: &str) -> Option<PathBuf> {
        if Path::new(name).is_absolute() {
            return Path::new(name).is_file().then(|| PathBuf::from(name));
        }
        self.search
            .dirs(kind)
            .iter()
            .map(|dir| dir.join(name))
            .chain(std::iter::once(r.resolve(name)))
            .find(|p| p.is_file())
    }

    /// Where [`Reader::find_file`] looks, for a message.
    pub(super) fn search_description(&self, kind: Kind, r: &Req<'_>) -> String {
        let mut places: Vec<String> = self
            .search
            .dirs(kind)
            .iter()
            .map(|d| d.display().to_string())
            .collect();
        // A RIB file named without a folder has an empty base: the current directory.
        places.push(if r.base.as_os_str().is_empty() {
            ".".to_string()
        } else {
            r.base.display().to_string()
        });
        format!("looked in {}", places.join(", "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_search_path_splits_and_keeps_the_previous_one_at_the_ampersand() {
        let base = Path::new("/scene");
        let previous = vec![PathBuf::from("/old")];
        assert_eq!(
            parse_path("maps:/abs/tex:&:@", base, &previous),
            vec![
                PathBuf::from("/scene/maps"),
                PathBuf::from("/abs/tex"),
                PathBuf::from("/old")
            ]
        );
        assert_eq!(parse_path("a;b", base, &[]), vec![base.join("a"), base.join("b")]);
        assert_eq!(parse_path(".", base, &[]), vec![PathBuf::from("/scene")]);
    }
}
