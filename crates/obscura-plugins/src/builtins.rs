//! The table of built-in projections: every projection of `obscura-projections` and the calibrated
//! camera of `obscura-calibration`, registered under their RenderMan names.

use obscura_calibration::CalibratedCameraFactory;
use obscura_host::Registry;

/// Adds every built-in projection to `registry`.
///
/// # Panics
/// When `registry` already holds a projection of a built-in's name (register built-ins first).
pub fn register_builtins(registry: &mut Registry) {
    let calibrated: Box<dyn obscura_sdk::ProjectionFactory> = Box::new(CalibratedCameraFactory);
    for factory in obscura_projections::factories().into_iter().chain([calibrated]) {
        registry.register(factory, "").expect("built-in names are unique");
    }
}

/// A registry holding every built-in projection.
#[must_use]
pub fn builtin_registry() -> Registry {
    let mut r = Registry::new();
    register_builtins(&mut r);
    r
}

/// The projections that only work with a file given (they have no usable defaults), registered by
/// [`cli_registry`] but not by [`register_builtins`]: `StMapCamera` (`string map`, the ST-map EXR,
/// and `float[4] pinhole` are required).
///
/// They are kept out of [`builtin_registry`] on purpose: every loop that runs each built-in with its
/// default parameters (the map test `every_registered_projection_maps_to_itself`, the fuzz targets,
/// `.ci/run`'s `obscura check` of each name `obscura plugins --names` prints, the gallery, the Python
/// listing) would fail on them for the missing file, not for a fault of the projection.
pub const FILE_PROJECTIONS: &[&str] = &[obscura_calibration::stmap::PROJECTION];

/// The registry `obscura rays`, `render`, `check` and `stmap` resolve projection names in: every
/// built-in plus the [`FILE_PROJECTIONS`], so `--projection StMapCamera --param 'string map' ...`
/// works from the command line.
#[must_use]
pub fn cli_registry() -> Registry {
    let mut r = builtin_registry();
    r.register(Box::new(obscura_calibration::stmap::StMapCameraFactory), "")
        .expect("file projections' names differ from the built-ins'");
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use obscura_sdk::{Format, ParamList, ProjectionEnvironment};

    #[test]
    fn the_cli_registry_adds_exactly_the_file_projections() {
        let builtins = builtin_registry().names();
        let cli = cli_registry().names();
        let extra: Vec<&String> = cli.iter().filter(|n| !builtins.contains(n)).collect();
        let extra: Vec<&str> = extra.into_iter().map(String::as_str).collect();
        assert_eq!(extra, FILE_PROJECTIONS);
        assert_eq!(cli.len(), builtins.len() + FILE_PROJECTIONS.len());
        // Without its map it is refused naming the missing parameter, not run with defaults.
        let mut env = ProjectionEnvironment::for_format(Format::new(4, 4));
        let err = cli_registry()
            .create(FILE_PROJECTIONS[0], &mut env, &ParamList::new())
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("map is required"), "{err}");
    }

    #[test]
    fn unknown_projection_lists_the_known_ones() {
        let mut reg = builtin_registry();
        let mut env = ProjectionEnvironment::for_format(Format::new(4, 4));
        let err = reg
            .create("PxrPerspectve", &mut env, &ParamList::new())
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("did you mean \"PxrPerspective\""), "{err}");
        let known = format!("known projections: {}", reg.names().join(", "));
        assert!(err.contains(&known), "{err}");
        assert!(reg.names().len() > 2, "{err}");
        assert!(reg.create("PxrOrthographic", &mut env, &ParamList::new()).is_ok());
    }

    #[test]
    fn every_builtin_table_has_documented_unique_parameters() {
        let reg = builtin_registry();
        for name in reg.names() {
            let f = reg.get(&name).unwrap();
            assert!(!f.summary().is_empty(), "{name}");
            let mut seen = std::collections::HashSet::new();
            for d in f.param_table() {
                assert!(!d.doc.is_empty(), "{name}.{} has no doc", d.name);
                assert!(seen.insert(d.name.clone()), "{name}.{} declared twice", d.name);
                assert_eq!(
                    d.default.len(),
                    d.scalar_count(),
                    "{name}.{} default has the wrong size",
                    d.name
                );
            }
        }
    }

    #[test]
    fn the_builtin_registry_holds_it() {
        let mut reg = builtin_registry();
        let mut env = ProjectionEnvironment::for_format(Format::new(4, 4));
        for name in ["PxrCamera", obscura_calibration::NAME] {
            assert!(reg.create(name, &mut env, &ParamList::new()).is_ok(), "{name}");
        }
    }
}
