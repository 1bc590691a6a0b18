//! Where plugin libraries are looked for: `--plugin-path` directories, then [`PLUGIN_PATH_VAR`], and
//! a projection `<Name>` as the file `<Name>.so` (`.dylib` on macOS, `.dll` on Windows).

use std::path::PathBuf;

use crate::isolate::Isolation;

pub use crate::library::PLUGIN_PATH_VAR;

/// Where plugin libraries are looked for, in order.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct PluginSearch {
    paths: Vec<PathBuf>,
    /// How many of `paths` came from the command line (searched before a scene's own directories).
    explicit: usize,
    isolation: Option<Isolation>,
}

impl PluginSearch {
    /// Searches exactly these directories, in order.
    #[must_use]
    pub fn new(paths: Vec<PathBuf>) -> Self {
        PluginSearch {
            explicit: paths.len(),
            paths,
            isolation: None,
        }
    }

    /// The same search, loading the plugins `isolation` names in worker processes
    /// ([`crate::isolate`]); `None` loads every plugin in process.
    #[must_use]
    pub fn with_isolation(mut self, isolation: Option<Isolation>) -> Self {
        self.isolation = isolation;
        self
    }

    /// Which plugins are loaded in worker processes.
    #[must_use]
    pub fn isolation(&self) -> Option<&Isolation> {
        self.isolation.as_ref()
    }

    /// `extra` (the CLI's `--plugin-path`, most specific first), then every directory of
    /// `OBSCURA_PLUGIN_PATH`.
    #[must_use]
    pub fn from_env(extra: &[PathBuf]) -> Self {
        let env = std::env::var_os(PLUGIN_PATH_VAR);
        Self::from_parts(extra, env.as_deref())
    }

    /// [`PluginSearch::from_env`] with the variable's value given (tests, tools).
    #[must_use]
    pub fn from_parts(extra: &[PathBuf], plugin_path: Option<&std::ffi::OsStr>) -> Self {
        let mut paths: Vec<PathBuf> = extra.to_vec();
        if let Some(v) = plugin_path {
            paths.extend(std::env::split_paths(v).filter(|p| !p.as_os_str().is_empty()));
        }
        PluginSearch {
            explicit: extra.len(),
            ..PluginSearch::new(paths)
        }
    }

    /// The same search with a scene's own plugin directories (RIB `Option "searchpath" "string
    /// rixplugin"`) after the command line's and before `OBSCURA_PLUGIN_PATH`'s.
    #[must_use]
    pub fn with_scene_dirs(&self, dirs: &[PathBuf]) -> Self {
        let mut paths = self.paths[..self.explicit].to_vec();
        paths.extend(dirs.iter().cloned());
        paths.extend(self.paths[self.explicit..].iter().cloned());
        PluginSearch {
            paths,
            explicit: self.explicit + dirs.len(),
            isolation: self.isolation.clone(),
        }
    }

    /// The directories, in search order.
    #[must_use]
    pub fn paths(&self) -> &[PathBuf] {
        &self.paths
    }

    /// Every plugin library along the path: each `*.so` (`.dylib`, `.dll`) file of each directory,
    /// sorted by file name, and only the first of a file name (the one `find` would take).
    /// Directories that cannot be read are skipped.
    #[must_use]
    pub fn libraries(&self) -> Vec<PathBuf> {
        let mut seen = std::collections::HashSet::new();
        let mut found = Vec::new();
        for dir in &self.paths {
            let Ok(entries) = std::fs::read_dir(dir) else {
                continue;
            };
            let mut here: Vec<PathBuf> = entries
                .filter_map(Result::ok)
                .map(|e| e.path())
                .filter(|p| p.is_file())
                .filter(|p| {
                    p.extension()
                        .is_some_and(|e| e == std::env::consts::DLL_EXTENSION)
                })
                .collect();
            here.sort();
            for p in here {
                if let Some(file) = p.file_name().map(std::ffi::OsStr::to_os_string)
                    && seen.insert(file)
                {
                    found.push(p);
                }
            }
        }
        found
    }

    /// The first `<name>.so` (`.dylib`, `.dll`) along the path that exists.
    #[must_use]
    pub fn find(&self, name: &str) -> Option<PathBuf> {
        let file = library_file_name(name);
        self.paths.iter().map(|d| d.join(&file)).find(|p| p.is_file())
    }
}

/// `<name>.so` on Linux, `<name>.dylib` on macOS, `<name>.dll` on Windows.
#[must_use]
pub fn library_file_name(name: &str) -> String {
    format!("{name}.{}", std::env::consts::DLL_EXTENSION)
}

/// True when `s` names a file rather than a projection: it has a path separator or a library
/// extension.
#[must_use]
pub fn looks_like_path(s: &str) -> bool {
    s.contains('/')
        || s.contains(std::path::MAIN_SEPARATOR)
        || [".so", ".dylib", ".dll"].iter().any(|e| s.ends_with(e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_command_line_comes_before_the_environment_and_empty_entries_are_skipped() {
        let sep = if cfg!(windows) { ";" } else { ":" };
        let var = format!("/a{sep}{sep}/b");
        let s = PluginSearch::from_parts(&[PathBuf::from("/cli")], Some(std::ffi::OsStr::new(&var)));
        assert_eq!(
            s.paths(),
            &[PathBuf::from("/cli"), PathBuf::from("/a"), PathBuf::from("/b")]
        );
    }

    #[test]
    fn a_search_finds_the_first_file_named_after_the_projection() {
        let a = tempfile::tempdir().unwrap();
        let b = tempfile::tempdir().unwrap();
        std::fs::write(b.path().join(library_file_name("Foo")), b"").unwrap();
        let s = PluginSearch::new(vec![a.path().into(), b.path().into()]);
        assert_eq!(s.find("Foo"), Some(b.path().join(library_file_name("Foo"))));
        assert_eq!(s.find("Bar"), None);
    }

    #[test]
    fn paths_are_told_from_names() {
        assert!(looks_like_path("./x.so") && looks_like_path("x.dylib") && looks_like_path("a/b"));
        assert!(!looks_like_path("PxrPerspective"));
    }
}
