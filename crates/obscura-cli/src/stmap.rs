//! `obscura stmap`: the ST-map between two projections (arguments only; the work is
//! [`obscura_image::stmap`]).

use std::path::{Path, PathBuf};

use crate::args::{load_calibration, parse_format};
use crate::params::{merge_param_args, param_list};
use crate::stdout::outln;
use clap::Args;
use obscura_host::Registry;
use obscura_image::stmap::{DEFAULT_DISTANCE, compute_stmap, stages, write_stmap_exr};
use obscura_plugins::loader::{PluginSearch, ensure};
use obscura_render::job::CALIBRATED;
use obscura_render::limits::{self, OutputKind};
use obscura_sdk::{Format, ParamList};

/// Arguments of `obscura stmap`.
#[derive(Args, Debug)]
pub struct StmapArgs {
    /// A: the projection the source image was made with (the STMap node's src input).
    #[arg(long, value_name = "NAME", required_unless_present = "from_calibration")]
    from: Option<String>,
    /// A is the real camera of this calibration file (COLMAP cameras.txt, OpenCV YAML/JSON, Kalibr
    /// camchain.yaml, OCamCalib calib_results.txt, a Nuke script with 3DE LD nodes, a 3DE lens export): map B = a pinhole to undistort its plates, or
    /// A = a pinhole and --to-calibration to distort renders to match them.
    #[arg(long, value_name = "FILE", conflicts_with = "from")]
    from_calibration: Option<PathBuf>,
    /// The camera of --from-calibration's file when it holds several (a COLMAP CAMERA_ID, Kalibr's cam0, a Nuke LD node's name, …).
    #[arg(long, value_name = "ID", requires = "from_calibration")]
    from_camera: Option<String>,
    /// A is the undistorted pinhole of --from-calibration's 3DEqualizer lens (what Nuke's LD_3DE4_*
    /// node undistorts the plate to, lens-centre offset included): with --to-calibration on the same
    /// file, the redistort map for an overscanned render (`obscura render --overscan`).
    #[arg(long, requires = "from_calibration")]
    from_undistorted: bool,
    /// A parameter of A: 'float fov=60', 'fov=60' or RIB's '"float fov" [60]'. Repeatable; with
    /// --from-calibration, adds to or replaces the calibration's parameters.
    #[arg(long = "from-param", value_name = "PARAM")]
    from_params: Vec<String>,
    /// B: the projection of the output image (the map has B's size).
    #[arg(long, value_name = "NAME", required_unless_present = "to_calibration")]
    to: Option<String>,
    /// B is the real camera of this calibration file (formats as --from-calibration).
    #[arg(long, value_name = "FILE", conflicts_with = "to")]
    to_calibration: Option<PathBuf>,
    /// The camera of --to-calibration's file when it holds several.
    #[arg(long, value_name = "ID", requires = "to_calibration")]
    to_camera: Option<String>,
    /// B is the undistorted pinhole of --to-calibration's 3DEqualizer lens: with --from-calibration
    /// on the same file, the plate's undistort map.
    #[arg(long, requires = "to_calibration")]
    to_undistorted: bool,
    /// A parameter of B, as --from-param. Repeatable.
    #[arg(long = "to-param", value_name = "PARAM")]
    to_params: Vec<String>,
    /// B's image size (the map's size), WIDTHxHEIGHT [default: the image size of --to-calibration,
    /// else of --from-calibration (a plate's undistorted twin), else 1920x1080].
    #[arg(long, value_parser = parse_format)]
    format: Option<(u32, u32)>,
    /// A's image size, WIDTHxHEIGHT [default: --from-calibration's image size, else B's].
    #[arg(long, value_parser = parse_format)]
    from_format: Option<(u32, u32)>,
    /// Distance along B's rays (scene units) of the point A's inverse is asked for. Only matters for
    /// projections whose rays do not all leave one point (stereo, orthographic).
    #[arg(long, default_value_t = DEFAULT_DISTANCE, allow_negative_numbers = true)]
    distance: f32,
    /// Output OpenEXR: R = s, G = t, B = 0, A = 1 where A's image holds the direction.
    #[arg(short, long, default_value = "stmap.exr")]
    output: PathBuf,
}

/// One side of the map, resolved: the projection's registered name, its parameters, the size of
/// a calibration's image (when the side is a calibration), its name in messages and what the EXR
/// records of it.
struct Side {
    name: String,
    params: ParamList,
    calibrated_size: Option<(u32, u32)>,
    label: String,
    record: String,
}

/// Resolves one side (`flag` is "--from" or "--to"): a projection by name (a built-in, a plugin on
/// the plugin path, or a plugin's path), or a calibration file's camera.
fn side(
    registry: &mut Registry,
    search: &PluginSearch,
    flag: &str,
    (name, calibration, camera): (Option<&str>, Option<&Path>, Option<&str>),
    args: &[String],
    undistorted: bool,
) -> Result<Side, String> {
    if let Some(path) = calibration {
        let mut calibrated =
            load_calibration(path, camera, true).map_err(|e| format!("{flag}-calibration: {e}"))?;
        if undistorted {
            calibrated = crate::overscan::undistorted(&calibrated, &format!("{flag}-undistorted"))?;
        }
        let (c, mut params) = (&calibrated.calibration, calibrated.params.clone());
        if let Some(note) = c.selection_note() {
            eprintln!("note: {}", note.replace("--camera", &format!("{flag}-camera")));
        }
        let factory = registry.find(CALIBRATED).map_err(|e| e.to_string())?;
        merge_param_args(&mut params, args, factory.name(), factory.param_table())
            .map_err(|e| format!("{flag}-param: {e}"))?;
        return Ok(Side {
            name: CALIBRATED.to_string(),
            params,
            calibrated_size: Some(calibrated.size()),
            label: match &c.camera {
                Some(id) => format!("{} camera {id}", c.file),
                None => c.file.clone(),
            },
            record: if undistorted {
                format!("the undistorted pinhole of {}", c.summary())
            } else {
                c.summary()
            },
        });
    }
    // Clap requires the name when there is no calibration.
    let name = name.ok_or_else(|| format!("{flag} NAME or {flag}-calibration FILE is required"))?;
    let registered = ensure(registry, name, search).map_err(|e| format!("{flag} {name}: {e}"))?;
    let factory = registry
        .find(&registered)
        .map_err(|e| format!("{flag} {name}: {e}"))?;
    let params =
        param_list(args, factory.name(), factory.param_table()).map_err(|e| format!("{flag}-param: {e}"))?;
    Ok(Side {
        name: registered,
        params,
        calibrated_size: None,
        label: name.to_string(),
        record: name.to_string(),
    })
}

/// Runs `obscura stmap` with the projections of `registry`.
///
/// # Errors
/// A message naming the option at fault, the projection or the file.
pub fn run(a: &StmapArgs, registry: &mut Registry, search: &PluginSearch) -> Result<(), String> {
    limits::check_output(&a.output, OutputKind::Exr).map_err(|e| e.to_string())?;
    // Either side may be a plugin on the plugin path, a path to one, or a calibration file; A is
    // resolved (and any error about it reported) before B.
    let options = [
        (
            "--from",
            &a.from,
            &a.from_calibration,
            &a.from_camera,
            &a.from_params,
            a.from_undistorted,
        ),
        (
            "--to",
            &a.to,
            &a.to_calibration,
            &a.to_camera,
            &a.to_params,
            a.to_undistorted,
        ),
    ];
    let mut sides = Vec::with_capacity(2);
    for (flag, name, calibration, camera, params, undistorted) in options {
        let given = (name.as_deref(), calibration.as_deref(), camera.as_deref());
        sides.push(side(registry, search, flag, given, params, undistorted)?);
    }
    let (from_side, to_side) = (&sides[0], &sides[1]);
    let (tw, th) = a
        .format
        .or(to_side.calibrated_size)
        .or(from_side.calibrated_size)
        .unwrap_or((1920, 1080));
    let to_format = Format::new(tw, th);
    let from_format = match a.from_format.or(from_side.calibrated_size) {
        Some((w, h)) => Format::new(w, h),
        None => to_format,
    };
    let to_source = if a.format.is_some() {
        "--format"
    } else {
        "the map's image size (--to-calibration)"
    };
    limits::check_image_size(tw, th, to_source).map_err(|e| e.to_string())?;
    let from_source = if a.from_format.is_some() {
        "--from-format"
    } else {
        "the source image size"
    };
    limits::check_image_size(from_format.width, from_format.height, from_source)
        .map_err(|e| e.to_string())?;
    limits::check_memory(
        limits::stmap_bytes(u64::from(tw) * u64::from(th)),
        &format!("a {tw}x{th} ST-map"),
    )
    .map_err(|e| e.to_string())?;
    let (from, to) = stages(
        registry,
        (&from_side.name, &from_side.params, from_format),
        (&to_side.name, &to_side.params, to_format),
    )
    .map_err(|e| e.to_string())?;
    for w in from.setup_warnings().iter().chain(to.setup_warnings()) {
        eprintln!("{w}");
    }
    let map = compute_stmap(&from, &to, a.distance).map_err(|e| e.to_string())?;
    let st = &map.stats;
    let (a_label, b_label) = (&from_side.label, &to_side.label);
    if let Some(w) = st.b_report.warning(b_label) {
        eprintln!("{w}");
    }
    if let Some(w) = st.a_report.warning(a_label) {
        eprintln!("{w}");
    }
    if let Some(w) = st.unproject_warning(a_label) {
        eprintln!("{w}");
    }
    if let Some(w) = st.consistency_warning(a_label) {
        eprintln!("{w}");
    }
    let attributes = [
        ("obscura:stmapFrom", from_side.record.clone()),
        ("obscura:stmapFromParameters", a.from_params.join("; ")),
        (
            "obscura:stmapFromFormat",
            format!("{}x{}", from_format.width, from_format.height),
        ),
        ("obscura:stmapTo", to_side.record.clone()),
        ("obscura:stmapToParameters", a.to_params.join("; ")),
        ("obscura:stmapDistance", a.distance.to_string()),
        (
            "obscura:stmapConvention",
            "Nuke STMap: R = s = x/W, G = t = 1 - y/H of the source (0,0 bottom-left corner); \
             A = 1 where the source image holds the direction"
                .to_string(),
        ),
    ];
    write_stmap_exr(&map, &attributes, &a.output).map_err(|e| e.to_string())?;
    outln!(
        "wrote {}: ST-map {} -> {} ({}x{} from {}x{}): {} of {} pixels mapped, {} culled by {}, \
         {} not seen by {}, {} outside its frame, {} culled by it",
        a.output.display(),
        a_label,
        b_label,
        to_format.width,
        to_format.height,
        from_format.width,
        from_format.height,
        st.mapped,
        st.pixels,
        st.culled_by_b,
        b_label,
        st.unseen_by_a,
        a_label,
        st.outside_a,
        st.culled_by_a
    );
    Ok(())
}
