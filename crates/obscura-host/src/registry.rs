//! Name → factory: how a host finds the projection a scene names.

use obscura_sdk::{
    ParamList, PluginError, Projection, ProjectionEnvironment, ProjectionFactory, SyncMessage, did_you_mean,
};

struct Entry {
    factory: Box<dyn ProjectionFactory>,
    path: String,
    initialized: bool,
    /// `RenderBegin` sent and `RenderEnd` not yet.
    rendering: bool,
}

/// The projections a host knows, by name.
///
/// The lifecycle of each factory, as RenderMan's: [`init`](ProjectionFactory::init) lazily, with the
/// path the factory was registered with, just before its first projection is created (registering or
/// listing runs none of a plugin's code);
/// [`synchronize`](ProjectionFactory::synchronize)`(RenderBegin)` once, right after, before the first
/// frame; `synchronize(RenderEnd)` once after the last frame ([`Registry::end_render`], or when the
/// registry is dropped); [`finalize`](ProjectionFactory::finalize) when the registry is dropped. So a
/// session only pays for the plugins it uses.
#[derive(Default)]
pub struct Registry {
    entries: Vec<Entry>,
}

impl std::fmt::Debug for Registry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Registry").field("names", &self.names()).finish()
    }
}

/// A second factory was registered under a name already taken.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("a projection named \"{0}\" is already registered")]
pub struct DuplicateName(pub String);

impl Registry {
    /// An empty registry.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a factory. `path` is where it was loaded from (empty for built-ins), handed to `init`.
    ///
    /// # Errors
    /// [`DuplicateName`] when the name is taken.
    pub fn register(&mut self, factory: Box<dyn ProjectionFactory>, path: &str) -> Result<(), DuplicateName> {
        if self.get(factory.name()).is_some() {
            return Err(DuplicateName(factory.name().to_string()));
        }
        self.entries.push(Entry {
            factory,
            path: path.to_string(),
            initialized: false,
            rendering: false,
        });
        Ok(())
    }

    /// Where the projection `name` was loaded from: `Some("")` for a built-in, `None` when unknown.
    #[must_use]
    pub fn path(&self, name: &str) -> Option<&str> {
        self.entries
            .iter()
            .find(|e| e.factory.name() == name)
            .map(|e| e.path.as_str())
    }

    /// Every registered name, sorted.
    #[must_use]
    pub fn names(&self) -> Vec<String> {
        let mut n: Vec<String> = self
            .entries
            .iter()
            .map(|e| e.factory.name().to_string())
            .collect();
        n.sort();
        n
    }

    /// The factory named `name`.
    #[must_use]
    pub fn get(&self, name: &str) -> Option<&dyn ProjectionFactory> {
        self.entries
            .iter()
            .find(|e| e.factory.name() == name)
            .map(|e| e.factory.as_ref())
    }

    /// The factory named `name`, or an error listing the known ones.
    ///
    /// # Errors
    /// [`PluginError::Unknown`] with a did-you-mean and every known name.
    pub fn find(&self, name: &str) -> Result<&dyn ProjectionFactory, PluginError> {
        self.get(name).ok_or_else(|| self.unknown(name))
    }

    fn unknown(&self, name: &str) -> PluginError {
        let known = self.names();
        PluginError::Unknown {
            name: name.to_string(),
            suggestion: did_you_mean(name, known.iter().map(String::as_str)),
            known,
        }
    }

    /// Creates the projection `name` for a camera: initialises its factory on first use, sends it
    /// `RenderBegin` when it is not rendering yet, and calls `create_projection`.
    ///
    /// # Errors
    /// An unknown name, a failing `init`, or the factory's own parameter errors.
    pub fn create(
        &mut self,
        name: &str,
        env: &mut ProjectionEnvironment,
        params: &ParamList,
    ) -> Result<Box<dyn Projection>, PluginError> {
        let Some(idx) = self.entries.iter().position(|e| e.factory.name() == name) else {
            return Err(self.unknown(name));
        };
        let entry = &mut self.entries[idx];
        if !entry.initialized {
            entry.factory.init(&entry.path)?;
            entry.initialized = true;
        }
        if !entry.rendering {
            entry.factory.synchronize(SyncMessage::RenderBegin, Some(params));
            entry.rendering = true;
        }
        entry.factory.create_projection(env, params)
    }

    /// Sends `RenderEnd` to every factory that was sent `RenderBegin`: call it after the last frame.
    /// A later [`Registry::create`] begins a new render. Dropping the registry calls it too.
    pub fn end_render(&mut self) {
        for e in self.entries.iter_mut().filter(|e| e.rendering) {
            e.factory.synchronize(SyncMessage::RenderEnd, None);
            e.rendering = false;
        }
    }
}

impl Drop for Registry {
    fn drop(&mut self) {
        self.end_render();
        for e in self.entries.iter_mut().filter(|e| e.initialized) {
            e.factory.finalize();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use obscura_sdk::ParamDecl;

    struct Named(&'static str);

    impl ProjectionFactory for Named {
        fn name(&self) -> &str {
            self.0
        }

        fn summary(&self) -> &str {
            "test factory"
        }

        fn param_table(&self) -> &[ParamDecl] {
            &[]
        }

        fn create_projection(
            &self,
            _env: &mut ProjectionEnvironment,
            _params: &ParamList,
        ) -> Result<Box<dyn Projection>, PluginError> {
            Err(PluginError::Unknown {
                name: self.0.into(),
                suggestion: None,
                known: Vec::new(),
            })
        }
    }

    #[test]
    fn path_says_where_each_projection_came_from_and_a_taken_name_is_refused() {
        let mut r = Registry::new();
        r.register(Box::new(Named("Built")), "").unwrap();
        r.register(Box::new(Named("Loaded")), "/plugins/Loaded.so")
            .unwrap();
        assert_eq!(r.path("Built"), Some(""));
        assert_eq!(r.path("Loaded"), Some("/plugins/Loaded.so"));
        assert_eq!(r.path("Nope"), None);
        let dup = r
            .register(Box::new(Named("Loaded")), "/elsewhere/Loaded.so")
            .unwrap_err();
        assert_eq!(dup.0, "Loaded");
        assert_eq!(r.path("Loaded"), Some("/plugins/Loaded.so"));
        assert_eq!(r.names(), ["Built", "Loaded"]);
    }

    type Log = std::sync::Arc<std::sync::Mutex<Vec<String>>>;

    /// A factory that writes down every lifecycle call it receives.
    struct Recorder(Log);

    impl ProjectionFactory for Recorder {
        fn name(&self) -> &str {
            "Recorder"
        }

        fn summary(&self) -> &str {
            "records its calls"
        }

        fn param_table(&self) -> &[ParamDecl] {
            &[]
        }

        fn init(&mut self, plugin_path: &str) -> Result<(), PluginError> {
            self.0.lock().unwrap().push(format!("init {plugin_path}"));
            Ok(())
        }

        fn finalize(&mut self) {
            self.0.lock().unwrap().push("finalize".into());
        }

        fn synchronize(&mut self, message: SyncMessage, params: Option<&ParamList>) {
            let with = if params.is_some() { "params" } else { "none" };
            self.0.lock().unwrap().push(format!("{message:?} {with}"));
        }

        fn create_projection(
            &self,
            _env: &mut ProjectionEnvironment,
            _params: &ParamList,
        ) -> Result<Box<dyn Projection>, PluginError> {
            self.0.lock().unwrap().push("create".into());
            Named("Built").create_projection(_env, _params)
        }
    }

    #[test]
    fn the_lifecycle_is_init_once_with_its_path_begin_once_end_once_finalize_once() {
        let log = Log::default();
        let mut r = Registry::new();
        r.register(Box::new(Recorder(log.clone())), "/plugins/Recorder.so")
            .unwrap();
        assert!(
            log.lock().unwrap().is_empty(),
            "registering runs none of the factory's code"
        );
        let mut env = ProjectionEnvironment::for_format(obscura_sdk::Format::new(4, 4));
        for _ in 0..3 {
            let _ = r.create("Recorder", &mut env, &ParamList::new());
        }
        r.end_render();
        let _ = r.create("Recorder", &mut env, &ParamList::new());
        drop(r);
        assert_eq!(
            *log.lock().unwrap(),
            [
                "init /plugins/Recorder.so",
                "RenderBegin params",
                "create",
                "create",
                "create",
                "RenderEnd none",
                "RenderBegin params",
                "create",
                "RenderEnd none",
                "finalize",
            ]
        );
    }

    #[test]
    fn an_unused_factory_is_never_initialised_nor_finalised() {
        let log = Log::default();
        let r = {
            let mut r = Registry::new();
            r.register(Box::new(Recorder(log.clone())), "").unwrap();
            r
        };
        assert_eq!(r.names(), ["Recorder"]);
        drop(r);
        assert!(log.lock().unwrap().is_empty());
    }
}
