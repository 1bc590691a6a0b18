//! `obscura stmap`: the ST-map between two projections (arguments only; the work is
//! [`obscura_host::stmap`]).

use std::path::PathBuf;

use clap::Args;
use obscura_host::cli_params::push_param_arg;
use obscura_host::plugins::{PluginSearch, ensure};
use obscura_host::stmap::{DEFAULT_DISTANCE, compute_stmap, stages, write_stmap_exr};
use obscura_sdk::{Format, ParamList, Registry};

/// Arguments of `obscura stmap`.
#[derive(Args, Debug)]
pub struct StmapArgs {
    /// A: the projection the source image was made with (the STMap node's src input).
    #[arg(long, value_name = "NAME")]
    from: String,
    /// A parameter of A: 'float fov=60', 'fov=60' or RIB's '"float fov" [60]'. Repeatable.
    #[arg(long = "from-param", value_name = "PARAM")]
    from_params: Vec<String>,
    /// B: the projection of the output image (the map has B's size).
    #[arg(long, value_name = "NAME")]
    to: String,
    /// A parameter of B, as --from-param. Repeatable.
    #[arg(long = "to-param", value_name = "PARAM")]
    to_params: Vec<String>,
    /// B's image size (the map's size), WIDTHxHEIGHT.
    #[arg(long, default_value = "1920x1080", value_parser = crate::parse_format)]
    format: (u32, u32),
    /// A's image size, WIDTHxHEIGHT (default: B's).
    #[arg(long, value_parser = crate::parse_format)]
    from_format: Option<(u32, u32)>,
    /// Distance along B's rays (scene units) of the point A's inverse is asked for. Only matters for
    /// projections whose rays do not all leave one point (stereo, orthographic).
    #[arg(long, default_value_t = DEFAULT_DISTANCE, allow_negative_numbers = true)]
    distance: f32,
    /// Output OpenEXR: R = s, G = t, B = 0, A = 1 where A's image holds the direction.
    #[arg(short, long, default_value = "stmap.exr")]
    output: PathBuf,
}

fn read_params(registry: &Registry, flag: &str, name: &str, args: &[String]) -> Result<ParamList, String> {
    let factory = registry.find(name).map_err(|e| format!("{flag} {name}: {e}"))?;
    let mut list = ParamList::new();
    for p in args {
        push_param_arg(&mut list, p, factory.name(), factory.param_table())
            .map_err(|e| format!("{flag}-param: {e}"))?;
    }
    Ok(list)
}

/// Runs `obscura stmap` with the projections of `registry`.
///
/// # Errors
/// A message naming the option at fault, the projection or the file.
pub fn run(a: &StmapArgs, registry: &mut Registry, search: &PluginSearch) -> Result<(), String> {
    // Either side may be a plugin on the plugin path, or a path to one.
    let from_name = ensure(registry, &a.from, search).map_err(|e| format!("--from {}: {e}", a.from))?;
    let to_name = ensure(registry, &a.to, search).map_err(|e| format!("--to {}: {e}", a.to))?;
    let from_params = read_params(registry, "--from", &from_name, &a.from_params)?;
    let to_params = read_params(registry, "--to", &to_name, &a.to_params)?;
    let to_format = Format::new(a.format.0, a.format.1);
    let from_format = a.from_format.map_or(to_format, |(w, h)| Format::new(w, h));
    let (from, to) = stages(
        registry,
        (&from_name, &from_params, from_format),
        (&to_name, &to_params, to_format),
    )
    .map_err(|e| e.to_string())?;
    for w in from.setup_warnings().iter().chain(to.setup_warnings()) {
        eprintln!("{w}");
    }
    let map = compute_stmap(&from, &to, a.distance).map_err(|e| e.to_string())?;
    let st = &map.stats;
    if let Some(w) = st.b_report.warning(&a.to) {
        eprintln!("{w}");
    }
    if let Some(w) = st.a_report.warning(&a.from) {
        eprintln!("{w}");
    }
    if let Some(w) = st.unproject_warning(&a.from) {
        eprintln!("{w}");
    }
    if let Some(w) = st.consistency_warning(&a.from) {
        eprintln!("{w}");
    }
    let attributes = [
        ("obscura:stmapFrom", a.from.clone()),
        ("obscura:stmapFromParameters", a.from_params.join("; ")),
        (
            "obscura:stmapFromFormat",
            format!("{}x{}", from_format.width, from_format.height),
        ),
        ("obscura:stmapTo", a.to.clone()),
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
    println!(
        "wrote {}: ST-map {} -> {} ({}x{} from {}x{}): {} of {} pixels mapped, {} culled by {}, \
         {} not seen by {}, {} outside its frame, {} culled by it",
        a.output.display(),
        a.from,
        a.to,
        to_format.width,
        to_format.height,
        from_format.width,
        from_format.height,
        st.mapped,
        st.pixels,
        st.culled_by_b,
        a.to,
        st.unseen_by_a,
        a.from,
        st.outside_a,
        st.culled_by_a
    );
    Ok(())
}
