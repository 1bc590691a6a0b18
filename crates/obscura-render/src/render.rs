//! The render loop: a scene in, a film (and optionally deep pixels) out.
//!
//! 1. **Setup** — the projection is created through the camera stage (its properties read once); every
//!    object is diced at the rate its DicingHint and FieldOfView ask for (in parallel); the two-level
//!    BVH is built over the meshes with object motion as instance transforms in shutter-normalised
//!    time; the lights are prepared (the dome's map importance-sampled).
//! 2. **Tiles** (rayon, 16×16 pixels) — for each pixel, `spp` Owen-scrambled Sobol samples go through
//!    the camera stage in batches of at most 4096 samples per tile: aperture and shutter warps,
//!    default-ray pre-fill, `project`, validation. Culled samples contribute nothing (RenderMan: a culled
//!    ray never writes its pixel) and are counted. Each camera-space ray is taken to world space with the
//!    camera's motion at that ray's own time; `min_dist`/`max_dist` bound the trace.
//! 3. **Shading** — the path tracer returns radiance and the first hit. The beauty `Ci` is radiance ×
//!    the projection's tint, *before* the pixel filter; alpha, z, N, P and cameraDirection are untinted.
//!    `z` is camera-space z of the hit (DeepMetric CameraZ) or the distance along the camera ray
//!    (RayLength), both in camera units.
//! 4. **Film** — the samples are splatted into a per-tile film with the pixel filter and merged.
//!
//! A cancel flag is checked between tiles: a cancelled render keeps what it finished.
//!
//! The code follows the same levels as Mitsuba's sampling integrator: `Prepared::render` runs the tiles
//! (in parallel, with progress and cancel) and merges each into a shared `Accumulator`;
//! `TileIntegrator::render_tile` runs one tile's camera batches into its film tile (`render_batch`:
//! generate, camera stage); `TileIntegrator::render_sample` is one sample's physics (`world_ray`,
//! `trace_path`, `aovs`, splat, deep).

use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use glam::{Affine3A, Mat4, Vec2, Vec3, Vec3A};
use obscura_host::Registry;
use obscura_host::driver::Properties;
use obscura_host::sampler::Sampler;
use obscura_host::{Batch, CameraDesc, CameraStage, ContractReport, HostError, PixelRect};
use obscura_scene::Scene;
use obscura_sdk::{DeepMetric, RayGeometry, Rgb};
use rayon::prelude::*;

use obscura_geometry::bvh::{Instance, RayVisibility, SceneAccel, SceneLayout};
use obscura_geometry::dice::{DiceError, DicingContext, TriangleBudget, dice_with_st};
use obscura_geometry::motion::Motion;
use obscura_geometry::motion::{camera_motion, object_motion};
use obscura_geometry::ray::{Ray, Tracer, TriangleMesh};
use obscura_geometry::rng::Rng;
use obscura_image::deep::{DeepImage, DeepSample};
use obscura_image::film::{Film, FilmTile, SampleValues};
use obscura_image::filter::{Filter, FilterError};
use obscura_image::samples::Truth;
use obscura_shading::integrator::{PathOptions, PathResult, RayCone, ShadingScene, trace_path_cone};
use obscura_shading::light::emissive::{EmissiveTriangles, EmitterCandidate};
use obscura_shading::light::{Lights, ShadeError};
use obscura_shading::material::textured::{SurfaceAttributes, TextureLookup, Texturing};

use crate::truth::IdTable;

/// Why a render could not start.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The camera or projection could not be set up.
    #[error(transparent)]
    Host(#[from] HostError),
    /// An object could not be diced.
    #[error("{source_location}: {error}")]
    Dice {
        /// Where the object was declared.
        source_location: String,
        /// Why.
        error: DiceError,
    },
    /// The pixel filter is invalid.
    #[error(transparent)]
    Filter(#[from] FilterError),
    /// The lights could not be prepared.
    #[error(transparent)]
    Lights(#[from] ShadeError),
    /// The camera transform cannot be inverted.
    #[error("{0}")]
    Camera(String),
    /// Too many samples per pixel.
    #[error("{0} samples per pixel: at most 65536 are supported")]
    TooManySamples(u32),
}

/// Knobs of one render that are not part of the scene.
#[derive(Debug, Clone)]
pub struct RenderOptions {
    /// Samples per pixel (default: the scene's).
    pub samples_per_pixel: Option<u32>,
    /// Seed of the sample sequences.
    pub seed: u32,
    /// Path depth.
    pub path: PathOptions,
    /// Collect deep samples (for a `deepexr` display).
    pub deep: bool,
    /// Tile edge in pixels.
    pub tile_size: u32,
    /// The most triangles the scene may dice into (see [`obscura_geometry::dice::TriangleBudget`]).
    pub max_triangles: u64,
    /// How textures are filtered (by the camera ray's footprint unless a comparison asks otherwise).
    pub texture_lookup: TextureLookup,
    /// How the accelerator stores static objects; `None`: as `OBSCURA_SCENE_LAYOUT` says
    /// ([`SceneLayout::from_env`], flattened into one world-space hierarchy by default).
    pub scene_layout: Option<SceneLayout>,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            samples_per_pixel: None,
            seed: 0,
            path: PathOptions::default(),
            deep: false,
            tile_size: 16,
            max_triangles: obscura_geometry::dice::DEFAULT_SCENE_TRIANGLES,
            texture_lookup: TextureLookup::Footprint,
            scene_layout: None,
        }
    }
}

/// Counts and times of one render.
#[derive(Debug, Clone, Default)]
pub struct RenderStats {
    /// Triangles after dicing, over all instances.
    pub triangles: usize,
    /// Seconds spent dicing and building the BVH.
    pub setup_seconds: f64,
    /// Seconds of the whole render (setup excluded).
    pub render_seconds: f64,
    /// Seconds spent in the camera stage's driver (aperture and shutter warps, default-ray pre-fill,
    /// `project`, validation), summed over threads.
    pub camera_stage_seconds: f64,
    /// Seconds spent generating the Sobol pixel, lens and time samples, summed over threads.
    pub sampling_seconds: f64,
    /// Rays traced through the BVH: camera rays, bounces and shadow rays.
    pub rays_traced: u64,
    /// [`RenderStats::rays_traced`] by kind.
    pub rays: RayCounts,
    /// Seconds spent tracing and shading (summed over threads).
    pub shading_seconds: f64,
    /// Wall-clock seconds of the flow pass (0 when no flow was asked for).
    pub flow_seconds: f64,
    /// Camera samples handed to the projection, culled ones and contract breaches.
    pub contract: ContractReport,
    /// Tiles finished / all tiles.
    pub tiles: (usize, usize),
    /// True when the render was cancelled before finishing.
    pub cancelled: bool,
    /// The tiles a cancelled render did not render, in tile order (empty when it finished).
    pub missing_tiles: Vec<PixelRect>,
}

/// Rays traced through the BVH, by kind (a ray passing a cut-out surface is traced again and counts
/// again).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RayCounts {
    /// Camera rays (nearest hit as camera rays see the scene).
    pub camera: u64,
    /// Bounce rays (nearest hit).
    pub bounce: u64,
    /// Shadow rays (any hit, or the nearest hit past surfaces that cast no shadow).
    pub shadow: u64,
}

impl RayCounts {
    /// All of them.
    #[must_use]
    pub fn total(&self) -> u64 {
        self.camera + self.bounce + self.shadow
    }
}

impl RenderStats {
    /// The text of a partial image's `obscura:partial` header attribute: which tiles are missing,
    /// as `x0-x1,y0-y1` pixel ranges (end exclusive); `None` when the render finished.
    #[must_use]
    pub fn partial_note(&self) -> Option<String> {
        if self.missing_tiles.is_empty() {
            return None;
        }
        let list: Vec<String> = self
            .missing_tiles
            .iter()
            .map(|r| format!("{}-{},{}-{}", r.x0, r.x1, r.y0, r.y1))
            .collect();
        Some(format!(
            "interrupted: {} of {} tiles rendered; missing tiles (x0-x1,y0-y1, end exclusive): {}",
            self.tiles.0,
            self.tiles.1,
            list.join(" ")
        ))
    }
}

/// A render ready to go: the projection, geometry and lights prepared.
pub struct Prepared {
    stage: CameraStage,
    accel: SceneAccel,
    shading: ShadingScene,
    filter: Filter,
    samples_per_pixel: u32,
    /// Camera-to-world over the shutter (shutter-normalised time).
    camera_to_world: Motion,
    deep_metric: DeepMetric,
    /// Textures that could not be used, one message each.
    texture_warnings: Vec<String>,
    /// What was chosen for the scene (automatic camera, default lights); empty when nothing was.
    info: String,
    /// Object, instance and material IDs of the scene's objects.
    ids: IdTable,
    /// `Exposure`, for the film's colour and the deep samples' gain.
    exposure: obscura_scene::Exposure,
    setup_seconds: f64,
}

impl std::fmt::Debug for Prepared {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Prepared")
            .field("projection", &self.stage.name())
            .field("triangles", &self.accel.triangle_count())
            .finish_non_exhaustive()
    }
}

/// Camera samples per batch handed to the camera stage: bounds memory at any sample count.
const CHUNK_SAMPLES: usize = 4096;

/// A 64-bit mixing hash (SplitMix64's finaliser): decorrelates seeds from pixel coordinates.
fn mix64(mut x: u64) -> u64 {
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

/// Counts the rays one tile traces by kind (camera, bounce and shadow queries); tile-local, so the
/// counts are free of contention.
struct CountingTracer<'a> {
    inner: &'a SceneAccel,
    camera: AtomicU64,
    bounce: AtomicU64,
    shadow: AtomicU64,
}

impl<'a> CountingTracer<'a> {
    fn new(inner: &'a SceneAccel) -> Self {
        CountingTracer {
            inner,
            camera: AtomicU64::new(0),
            bounce: AtomicU64::new(0),
            shadow: AtomicU64::new(0),
        }
    }

    fn counts(self) -> RayCounts {
        RayCounts {
            camera: self.camera.into_inner(),
            bounce: self.bounce.into_inner(),
            shadow: self.shadow.into_inner(),
        }
    }
}

impl Tracer for CountingTracer<'_> {
    fn intersect(&self, ray: &Ray) -> Option<obscura_geometry::ray::Hit> {
        self.bounce.fetch_add(1, Ordering::Relaxed);
        self.inner.intersect(ray)
    }
    fn occluded(&self, ray: &Ray) -> bool {
        self.shadow.fetch_add(1, Ordering::Relaxed);
        self.inner.occluded(ray)
    }
    fn intersect_camera(&self, ray: &Ray) -> Option<obscura_geometry::ray::Hit> {
        self.camera.fetch_add(1, Ordering::Relaxed);
        self.inner.intersect_camera(ray)
    }
    fn intersect_shadow(&self, ray: &Ray) -> Option<obscura_geometry::ray::Hit> {
        self.shadow.fetch_add(1, Ordering::Relaxed);
        self.inner.intersect_shadow(ray)
    }
}

/// Sets up a render of `scene`: projection, dicing, BVH, lights.
///
/// # Errors
/// A [`RenderError`] naming what could not be prepared.
pub fn prepare(
    scene: &Scene,
    registry: &mut Registry,
    base_dir: &Path,
    opts: &RenderOptions,
) -> Result<Prepared, RenderError> {
    let start = Instant::now();
    let base = scene.projection_base.as_ref();
    let mut stage = CameraStage::chained(
        registry,
        base,
        &scene.projection,
        &scene.projection_params,
        &scene.camera,
    )?;
    let staged = crate::staging::Staged::new(scene, &stage);
    if let Some(camera) = &staged.camera {
        stage = CameraStage::chained(
            registry,
            base,
            &scene.projection,
            &scene.projection_params,
            camera,
        )?;
    }
    let props = *stage.properties();
    let shutter = scene.camera.shutter;
    let camera_to_world =
        camera_motion(stage.environment().world_to_camera(), shutter).map_err(RenderError::Camera)?;
    let world_to_camera_open = camera_to_world.object_to_world(0.0).inverse();
    let (meshes, diced_st): (Vec<TriangleMesh>, Vec<Option<Vec<Vec2>>>) =
        dice_objects(scene, &props, world_to_camera_open, opts.max_triangles)?
            .into_iter()
            .unzip();
    let instances: Vec<Instance> = scene
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| Instance {
            mesh: i as u32,
            transform: object_motion(&o.transform.samples, shutter),
        })
        .collect();
    let (mut texturing, texture_warnings) = Texturing::new(
        &scene.textures,
        scene.material_maps.clone(),
        scene
            .objects
            .iter()
            .zip(meshes.iter().zip(diced_st))
            .map(|(o, (mesh, st))| match &o.shape {
                obscura_scene::Shape::Mesh(m) => SurfaceAttributes::of_mesh(m).map(Arc::new),
                _ if scene.material_maps.contains_key(&o.material) => st
                    .and_then(|st| SurfaceAttributes::of_diced(mesh, &st))
                    .map(Arc::new),
                _ => None,
            })
            .collect(),
        base_dir,
    );
    texturing.lookup = opts.texture_lookup;
    let emissive = EmissiveTriangles::new(
        &(meshes.iter().zip(&instances).zip(&scene.objects))
            .map(|((mesh, instance), o)| EmitterCandidate {
                mesh,
                transform: &instance.transform,
                material: scene
                    .materials
                    .get(o.material as usize)
                    .copied()
                    .unwrap_or_default(),
                material_index: o.material,
            })
            .collect::<Vec<_>>(),
        &texturing,
    );
    // Static objects go into one world-space hierarchy (`SceneLayout::Flat`) unless some rays do not
    // see them; moving ones stay instances. Object IDs are the instance indices either way.
    let visibility = RayVisibility {
        sides: camera_sides(scene),
        camera: scene.objects.iter().map(|o| o.visibility.camera).collect(),
        shadows: scene.objects.iter().map(|o| o.visibility.shadows).collect(),
        clip_planes: clip_planes(scene, &camera_to_world),
    };
    let layout = opts.scene_layout.unwrap_or_else(SceneLayout::from_env);
    let accel = SceneAccel::build_with(meshes, instances, visibility, layout);
    let shading = ShadingScene {
        materials: scene.materials.clone(),
        instance_material: scene.objects.iter().map(|o| o.material).collect(),
        lights: Lights::new(&staged.lights, base_dir)?,
        texturing,
        emissive,
        local_shading: (0..scene.materials.len() as u32)
            .map(|m| scene.local_shading.get(&m).copied())
            .collect(),
    };
    let spp = opts.samples_per_pixel.unwrap_or(scene.samples_per_pixel).max(1);
    if spp > obscura_host::sampler::MAX_SAMPLES {
        return Err(RenderError::TooManySamples(spp));
    }
    Ok(Prepared {
        filter: Filter::new(&scene.filter)?,
        deep_metric: props.deep_metric,
        stage,
        accel,
        shading,
        samples_per_pixel: spp,
        camera_to_world,
        texture_warnings: texture_warnings.into_iter().map(|w| w.0).collect(),
        info: staged.notes.join("; "),
        ids: IdTable::new(scene),
        exposure: scene.exposure,
        setup_seconds: start.elapsed().as_secs_f64(),
    })
}

/// Which sides camera rays see of each object. Curves and points face the camera by construction and
/// blobs are diced without a defined winding, so they show both.
fn camera_sides(scene: &Scene) -> Vec<obscura_scene::Sides> {
    use obscura_scene::{Shape, Sides};
    (scene.objects.iter())
        .map(|o| match o.shape {
            Shape::Curves(_) | Shape::Points(_) | Shape::Blobby(_) => Sides::Both,
            _ => o.sides,
        })
        .collect()
}

/// The scene's clipping planes in world space, `(point, normal)`: those given in camera space placed
/// by the camera at shutter open.
fn clip_planes(scene: &Scene, camera_to_world: &Motion) -> Vec<(Vec3A, Vec3A)> {
    let c2w = camera_to_world.object_to_world(0.0);
    let normal_to_world = c2w.matrix3.inverse().transpose();
    (scene.clip_planes.iter())
        .map(|c| {
            let (p, n) = (Vec3A::from(c.point), Vec3A::from(c.normal));
            match c.space {
                obscura_scene::ClipSpace::World => (p, n),
                obscura_scene::ClipSpace::Camera => (c2w.transform_point3a(p), normal_to_world * n),
            }
        })
        .collect()
}

/// A diced object: its triangles and, for primitives that carry them, each vertex's `(s, t)`.
type Diced = (TriangleMesh, Option<Vec<Vec2>>);

/// Every object of `scene` diced (in parallel) at the rate the projection's DicingHint and FieldOfView
/// ask for, seen from the camera at shutter open.
///
/// # Errors
/// [`RenderError::Dice`] for the first object (in scene order) that cannot be diced.
fn dice_objects(
    scene: &Scene,
    props: &Properties,
    world_to_camera_open: Affine3A,
    max_triangles: u64,
) -> Result<Vec<Diced>, RenderError> {
    // The memory a job may use bounds the triangles too: past it the allocator would abort the
    // process; here the primitive that goes over is named. (A malformed OBSCURA_MEMORY_LIMIT was
    // refused before the render, by the job's memory check.)
    let memory = crate::limits::memory_limit().ok().flatten();
    let budget = TriangleBudget::within_memory(max_triangles, memory.as_ref().map(|(b, s)| (*b, s.as_str())));
    let diced: Vec<Result<Diced, RenderError>> = scene
        .objects
        .par_iter()
        .map(|o| {
            if budget.exhausted() {
                // Another primitive has already gone over: this one's own message would mislead.
                return Ok((TriangleMesh::default(), None));
            }
            let object_to_world = o.transform.samples.first().map(|s| s.1).unwrap_or(Mat4::IDENTITY);
            let ctx = DicingContext {
                hint: props.dicing_hint,
                field_of_view: props.field_of_view.unwrap_or(90.0),
                format: scene.camera.format,
                screen_window: scene.camera.screen_window(),
                object_to_camera: Mat4::from(world_to_camera_open) * object_to_world,
                micropolygon_length: o.micropolygon_length,
            };
            let located = |error| RenderError::Dice {
                source_location: o.source.clone(),
                error,
            };
            let (mesh, st) = dice_with_st(&o.shape, &ctx).map_err(located)?;
            budget.take(mesh.len() as u64).map_err(located)?;
            Ok((mesh, st))
        })
        .collect();
    diced.into_iter().collect()
}

/// The finished (or cancelled) render.
#[derive(Debug)]
pub struct RenderOutput {
    /// The filtered AOVs.
    pub film: Film,
    /// Per-sample deep data, when asked for.
    pub deep: Option<DeepImage>,
    /// Counts and times.
    pub stats: RenderStats,
    /// The sensor stage's result, when the scene has a sensor ([`crate::sensor::expose`]).
    pub sensor: Option<crate::sensor::SensorOutput>,
}

impl Prepared {
    /// The camera stage (projection, properties, warnings).
    #[must_use]
    pub fn stage(&self) -> &CameraStage {
        &self.stage
    }

    /// The scene accelerator.
    #[must_use]
    pub fn accel(&self) -> &SceneAccel {
        &self.accel
    }

    /// One line saying what the renderer chose for the scene (the automatic camera for this
    /// projection, the default lights); empty when the scene chose everything itself.
    #[must_use]
    pub fn info(&self) -> &str {
        &self.info
    }

    /// One warning per texture that could not be read or decoded (its material uses the factor).
    #[must_use]
    pub fn texture_warnings(&self) -> &[String] {
        &self.texture_warnings
    }

    /// How many emissive triangles light sampling aims at (the emitters that neither move nor have
    /// alpha cut-outs; see [`obscura_shading::light::emissive`]).
    #[must_use]
    pub fn emissive_triangles(&self) -> usize {
        self.shading.emissive.len()
    }

    /// Bytes held by the loaded textures' mip pyramids.
    #[must_use]
    pub fn texture_memory_bytes(&self) -> usize {
        self.shading.texturing.memory_bytes()
    }

    /// The scene's object, instance and material IDs.
    #[must_use]
    pub fn ids(&self) -> &IdTable {
        &self.ids
    }

    /// The camera-space ray taken to world space with the camera's motion at `time`; its `min_dist` and
    /// `max_dist` become world-space bounds. `None` when the transform collapses or blows up the
    /// direction.
    pub(crate) fn world_ray(&self, r: &RayGeometry, time: f32) -> Option<WorldRay> {
        let c2w = self.camera_to_world.object_to_world(time);
        let origin_cam = Vec3A::new(r.origin.x, r.origin.y, r.origin.z);
        // Normalised here so that a ray length is exact even for a projection whose directions are unit
        // only to the contract's tolerance.
        let direction_cam = Vec3A::new(r.direction.x, r.direction.y, r.direction.z).normalize();
        let d_world = c2w.transform_vector3a(direction_cam);
        let stretch = d_world.length();
        if !(stretch > 0.0 && stretch.is_finite()) {
            return None;
        }
        Some(WorldRay {
            ray: Ray {
                origin: c2w.transform_point3a(origin_cam),
                direction: d_world / stretch,
                t_min: r.min_dist * stretch,
                t_max: r.max_dist * stretch,
                time,
            },
            origin_cam,
            direction_cam,
            stretch,
            camera_to_world: c2w,
        })
    }

    /// Renders every tile of the crop. `progress(done, total)` is called after each tile; `cancel` is
    /// checked before each tile.
    ///
    /// The tiles run in parallel (`TileIntegrator::render_tile`); each finished tile is merged into the
    /// shared `Accumulator` in whatever order the tiles finish.
    pub fn render(
        &self,
        opts: &RenderOptions,
        progress: &(dyn Fn(usize, usize) + Sync),
        cancel: &AtomicBool,
    ) -> RenderOutput {
        let start = Instant::now();
        let cam = self.stage.camera();
        let tiles = tile_grid(cam.pixels(), opts.tile_size);
        let integrator = TileIntegrator::new(self, opts);
        let accumulator = Accumulator::new(cam, self.filter, opts.deep);
        let skipped = Mutex::new(Vec::new());
        tiles.par_iter().enumerate().for_each(|(index, rect)| {
            if cancel.load(Ordering::Relaxed) {
                skipped
                    .lock()
                    .expect("no panics while holding the list")
                    .push(index);
                return;
            }
            let tile = integrator.render_tile(*rect, &accumulator);
            let done = accumulator.merge(tile);
            progress(done, tiles.len());
        });
        let mut skipped = skipped.into_inner().expect("no panics while holding the list");
        skipped.sort_unstable();
        let mut out = accumulator.finish(self, start, tiles.len());
        out.stats.missing_tiles = skipped.into_iter().map(|i| tiles[i]).collect();
        out
    }
}

/// The crop cut into tiles of `tile_size` pixels (at least 1), row by row; the last row and column of
/// tiles are cut short at the crop's edge.
fn tile_grid(crop: PixelRect, tile_size: u32) -> Vec<PixelRect> {
    let ts = tile_size.max(1);
    let mut tiles = Vec::new();
    let mut y = crop.y0;
    while y < crop.y1 {
        let mut x = crop.x0;
        while x < crop.x1 {
            tiles.push(PixelRect {
                x0: x,
                x1: (x + ts).min(crop.x1),
                y0: y,
                y1: (y + ts).min(crop.y1),
            });
            x += ts;
        }
        y += ts;
    }
    tiles
}

/// One pixel's deep data while the render runs: the samples that hit something, and how many samples
/// the camera stage kept in all (the coverage denominator of [`composite_deep`]).
type DeepPixel = (Vec<DeepSample>, u32);

/// What the tiles share: the film, the deep pixels, the contract report and the counters, each merged
/// into once per finished tile.
struct Accumulator {
    film: Mutex<Film>,
    /// One entry per crop pixel; `None` when no deep output was asked for.
    deep: Option<Mutex<Vec<DeepPixel>>>,
    report: Mutex<ContractReport>,
    /// Tiles finished.
    done: AtomicUsize,
    rays: [AtomicU64; 3],
    sampling_ns: AtomicU64,
    camera_ns: AtomicU64,
    shading_ns: AtomicU64,
}

impl Accumulator {
    /// An empty film (and deep image) over `cam`'s crop.
    fn new(cam: &CameraDesc, filter: Filter, deep: bool) -> Self {
        let crop = cam.pixels();
        Accumulator {
            film: Mutex::new(Film::new(cam.format.width, cam.format.height, crop, filter)),
            deep: deep.then(|| Mutex::new(vec![(Vec::new(), 0); crop.len()])),
            report: Mutex::new(ContractReport::default()),
            done: AtomicUsize::new(0),
            rays: Default::default(),
            sampling_ns: AtomicU64::new(0),
            camera_ns: AtomicU64::new(0),
            shading_ns: AtomicU64::new(0),
        }
    }

    /// An empty film tile for `rect`, to be filled by one thread.
    fn film_tile(&self, rect: PixelRect) -> FilmTile {
        self.film
            .lock()
            .expect("no panics while holding the film")
            .tile(rect)
    }

    /// Adds a finished tile; returns how many tiles are finished now.
    fn merge(&self, tile: FinishedTile) -> usize {
        let add = |counter: &AtomicU64, value: u64| counter.fetch_add(value, Ordering::Relaxed);
        let rays = [tile.rays.camera, tile.rays.bounce, tile.rays.shadow];
        for (counter, n) in self.rays.iter().zip(rays) {
            add(counter, n);
        }
        add(&self.sampling_ns, tile.sampling.as_nanos() as u64);
        add(&self.camera_ns, tile.camera.as_nanos() as u64);
        add(&self.shading_ns, tile.shading.as_nanos() as u64);
        self.film
            .lock()
            .expect("no panics while holding the film")
            .merge(tile.film);
        self.report
            .lock()
            .expect("no panics while holding the report")
            .merge(&tile.report);
        if let Some(deep) = &self.deep {
            let mut pixels = deep.lock().expect("no panics while holding the deep pixels");
            for (index, sample) in tile.deep {
                let pixel = &mut pixels[index];
                pixel.1 += 1;
                if let Some(sample) = sample {
                    pixel.0.push(sample);
                }
            }
        }
        self.done.fetch_add(1, Ordering::Relaxed) + 1
    }

    /// The output of a render of `total` tiles that started at `start` (after setup).
    fn finish(self, prepared: &Prepared, start: Instant, total: usize) -> RenderOutput {
        let cam = prepared.stage.camera();
        let finished = self.done.into_inner();
        let seconds = |ns: AtomicU64| ns.into_inner() as f64 * 1e-9;
        // Deep samples take the exposure's gain, which composites exactly; a gamma cannot be applied
        // before compositing (the reader warns when a deep display meets a gamma other than 1).
        let gain = prepared.exposure.gain;
        let deep = self.deep.map(|pixels| DeepImage {
            width: cam.format.width,
            height: cam.format.height,
            data_window: cam.pixels(),
            pixels: pixels
                .into_inner()
                .expect("no panics while holding the deep pixels")
                .into_iter()
                .map(|(samples, alive)| {
                    let mut composited = composite_deep(samples, alive);
                    if gain != 1.0 {
                        for s in &mut composited {
                            (s.r, s.g, s.b) = (s.r * gain, s.g * gain, s.b * gain);
                        }
                    }
                    composited
                })
                .collect(),
        });
        let [camera, bounce, shadow] = self.rays.map(AtomicU64::into_inner);
        let rays = RayCounts {
            camera,
            bounce,
            shadow,
        };
        let mut film = self.film.into_inner().expect("no panics while holding the film");
        film.set_exposure(prepared.exposure);
        RenderOutput {
            film,
            deep,
            stats: RenderStats {
                triangles: prepared.accel.triangle_count(),
                setup_seconds: prepared.setup_seconds,
                render_seconds: start.elapsed().as_secs_f64(),
                camera_stage_seconds: seconds(self.camera_ns),
                sampling_seconds: seconds(self.sampling_ns),
                rays_traced: rays.total(),
                rays,
                shading_seconds: seconds(self.shading_ns),
                flow_seconds: 0.0,
                contract: self
                    .report
                    .into_inner()
                    .expect("no panics while holding the report"),
                tiles: (finished, total),
                cancelled: finished < total,
                missing_tiles: Vec::new(),
            },
            sensor: None,
        }
    }
}

/// What every tile reads: the prepared scene, the options and the sample sequences (Mitsuba's
/// `render_block` / `render_sample` split: [`TileIntegrator::render_tile`] runs a tile's camera
/// batches, [`TileIntegrator::render_sample`] is one camera sample's physics).
struct TileIntegrator<'a> {
    prepared: &'a Prepared,
    opts: &'a RenderOptions,
    sampler: Sampler,
    /// The pixels rendered (and stored).
    crop: PixelRect,
    /// Pixels outside the crop whose samples the filter can still bring in (see [`sample_pixels`]).
    margin: u32,
    /// `mix64(seed)`: the part of every path's random stream that depends on the seed alone.
    path_seed: u64,
}

/// One tile while it renders: its film tile, its deep samples, its own ray counter, its share of the
/// contract report and its times.
struct TileState<'a> {
    film: FilmTile,
    /// `(pixel index in the crop, the sample's deep value when it hit something)`: one entry per sample
    /// inside the crop that survived the camera stage, so deep coverage counts exactly those.
    deep: Vec<(usize, Option<DeepSample>)>,
    tracer: CountingTracer<'a>,
    report: ContractReport,
    sampling: Duration,
    camera: Duration,
}

/// A tile's results, ready to merge into the [`Accumulator`].
struct FinishedTile {
    film: FilmTile,
    deep: Vec<(usize, Option<DeepSample>)>,
    report: ContractReport,
    rays: RayCounts,
    /// Generating the Sobol samples.
    sampling: Duration,
    /// In the camera stage.
    camera: Duration,
    /// The rest of the tile's time: tracing, shading and splatting.
    shading: Duration,
}

/// The camera samples of some pixels on their way through the camera stage, with each sample's raster
/// position (where it is splatted).
struct SampleBatch {
    camera: Batch,
    rasters: Vec<(f32, f32)>,
}

/// One camera sample as the camera stage left it: sample `index` of `pixel`, splatted at `raster`, with
/// the projection's camera-space ray, time and tint.
struct ProjectedSample {
    pixel: (u32, u32),
    index: u32,
    raster: (f32, f32),
    ray: RayGeometry,
    time: f32,
    tint: Rgb,
}

/// A camera ray taken to world space at its own time.
pub(crate) struct WorldRay {
    pub(crate) ray: Ray,
    /// The camera-space origin and (normalised) direction the ray came from.
    pub(crate) origin_cam: Vec3A,
    pub(crate) direction_cam: Vec3A,
    /// The length the camera-to-world transform gives a unit camera-space direction: camera-space
    /// distances times `stretch` are world-space distances.
    pub(crate) stretch: f32,
    /// Camera-to-world at the ray's time.
    pub(crate) camera_to_world: Affine3A,
}

impl<'a> TileIntegrator<'a> {
    fn new(prepared: &'a Prepared, opts: &'a RenderOptions) -> Self {
        let (fx, fy) = prepared.filter.radius();
        TileIntegrator {
            prepared,
            opts,
            sampler: Sampler::new(opts.seed),
            crop: prepared.stage.camera().pixels(),
            margin: ((fx.max(fy) - 0.5).max(0.0)).ceil() as u32,
            path_seed: mix64(opts.seed as u64),
        }
    }

    /// Renders one tile: its pixels (and its share of the filter margin, [`sample_pixels`]) go through
    /// the camera stage in batches of at most [`CHUNK_SAMPLES`] samples, whatever the sample count.
    fn render_tile(&self, rect: PixelRect, accumulator: &Accumulator) -> FinishedTile {
        let start = Instant::now();
        let spp = self.prepared.samples_per_pixel as usize;
        let pixels = sample_pixels(
            &rect,
            &self.crop,
            self.margin,
            self.prepared.stage.camera().format,
        );
        let mut tile = TileState {
            film: accumulator.film_tile(rect),
            deep: Vec::new(),
            tracer: CountingTracer::new(&self.prepared.accel),
            report: ContractReport::default(),
            sampling: Duration::ZERO,
            camera: Duration::ZERO,
        };
        let chunk_pixels = (CHUNK_SAMPLES / spp).max(1);
        let mut batch = SampleBatch {
            camera: Batch::with_capacity(chunk_pixels * spp),
            rasters: Vec::with_capacity(chunk_pixels * spp),
        };
        for chunk in pixels.chunks(chunk_pixels) {
            self.render_batch(chunk, &mut batch, &mut tile);
        }
        let elapsed = start.elapsed();
        FinishedTile {
            shading: elapsed.saturating_sub(tile.sampling + tile.camera),
            rays: tile.tracer.counts(),
            film: tile.film,
            deep: tile.deep,
            report: tile.report,
            sampling: tile.sampling,
            camera: tile.camera,
        }
    }

    /// Every sample of `pixels`: generated, run through the camera stage as one batch, then rendered
    /// one by one (culled samples contribute nothing).
    fn render_batch(&self, pixels: &[(u32, u32)], batch: &mut SampleBatch, tile: &mut TileState<'_>) {
        let spp = self.prepared.samples_per_pixel;
        let sampling = Instant::now();
        self.generate(pixels, batch);
        let camera = Instant::now();
        tile.report.merge(&self.prepared.stage.run(&mut batch.camera));
        let shading = Instant::now();
        tile.sampling += camera - sampling;
        tile.camera += shading - camera;
        let samples = pixels
            .iter()
            .flat_map(|&pixel| (0..spp).map(move |index| (pixel, index)));
        for (i, (pixel, index)) in samples.enumerate() {
            let ray = batch.camera.rays[i];
            if ray.is_culled() {
                continue;
            }
            let sample = ProjectedSample {
                pixel,
                index,
                raster: batch.rasters[i],
                ray,
                time: batch.camera.time[i],
                tint: batch.camera.tint[i],
            };
            self.render_sample(tile, &sample);
        }
    }

    /// Fills `batch` with the Sobol samples of `pixels`, pixel by pixel, `spp` each: raster position
    /// (pixel + offset), screen position, lens sample and canonical time.
    fn generate(&self, pixels: &[(u32, u32)], batch: &mut SampleBatch) {
        let cam = self.prepared.stage.camera();
        batch.camera.clear();
        batch.rasters.clear();
        for &(px, py) in pixels {
            for s in 0..self.prepared.samples_per_pixel {
                let c = self.sampler.sample(px, py, s);
                let raster = (px as f64 + c.pixel.0 as f64, py as f64 + c.pixel.1 as f64);
                batch.rasters.push((raster.0 as f32, raster.1 as f32));
                batch.camera.push(
                    cam.raster_to_screen(raster.0, raster.1),
                    obscura_sdk::Point2::new(c.lens.0, c.lens.1),
                    c.time,
                );
            }
        }
    }

    /// One camera sample: its ray to world space at its own time, the path traced, its AOVs splatted
    /// (and its deep value kept, when asked for).
    fn render_sample(&self, tile: &mut TileState<'_>, sample: &ProjectedSample) {
        let Some(world) = self.prepared.world_ray(&sample.ray, sample.time) else {
            return;
        };
        let (px, py) = sample.pixel;
        let mut rng = Rng::new(
            ((px as u64) << 32 | py as u64) ^ self.path_seed,
            sample.index as u64,
        );
        // The cone in world units: distances scale by `stretch`, angles do not.
        let cone = RayCone {
            width: sample.ray.origin_radius * world.stretch,
            spread: sample.ray.ray_spread,
        };
        let path = trace_path_cone(
            &self.prepared.shading,
            &tile.tracer,
            &world.ray,
            cone,
            &mut rng,
            &self.opts.path,
        );
        let values = self.aovs(&path, &world, sample.tint);
        tile.film.add_sample(sample.raster.0, sample.raster.1, &values);
        if self.opts.deep
            && let Some(pixel_index) = crop_index(&self.crop, px, py)
        {
            let deep = path.first_hit.is_some().then_some(DeepSample {
                z: values.z,
                z_back: values.z,
                r: values.ci.r,
                g: values.ci.g,
                b: values.ci.b,
                a: path.alpha,
            });
            tile.deep.push((pixel_index, deep));
        }
    }

    /// The sample's AOVs: `Ci` is the radiance times the projection's tint; alpha, z (camera units, in
    /// the projection's deep metric), N, P and cameraDirection are untinted.
    fn aovs(&self, path: &PathResult, world: &WorldRay, tint: Rgb) -> SampleValues {
        let radiance = path.radiance;
        let ci = Rgb::new(radiance.x * tint.r, radiance.y * tint.g, radiance.z * tint.b);
        let (z, n, p, truth) = match path.first_hit {
            Some(h) => {
                let t_cam = h.t / world.stretch;
                let p_camera = world.origin_cam + world.direction_cam * t_cam;
                let z = match self.prepared.deep_metric {
                    DeepMetric::CameraZ => p_camera.z,
                    DeepMetric::RayLength => t_cam,
                };
                // Normals go to camera space by the inverse transpose of world-to-camera, which is the
                // transpose of camera-to-world's linear part.
                let n_camera = world
                    .camera_to_world
                    .matrix3
                    .transpose()
                    .mul_vec3a(h.shading_normal)
                    .normalize_or_zero();
                let (object_id, instance_id, material_id) = self.prepared.ids.ids(h.instance);
                let truth = Truth {
                    camera_z: p_camera.z,
                    distance: t_cam,
                    p_camera: p_camera.into(),
                    n_camera: n_camera.into(),
                    object_id,
                    instance_id,
                    material_id,
                };
                (z, Vec3::from(h.shading_normal), Vec3::from(h.position), truth)
            }
            None => (f32::INFINITY, Vec3::ZERO, Vec3::ZERO, Truth::EMPTY),
        };
        SampleValues {
            ci,
            alpha: path.alpha,
            z,
            n,
            p,
            camera_direction: Vec3::from(world.ray.direction),
            albedo: Rgb::new(path.albedo.x, path.albedo.y, path.albedo.z),
            uv: path.uv,
            truth,
            flow: obscura_image::samples::FlowPixel::NONE,
            sensor: obscura_image::film::SensorPixel::default(),
        }
    }
}

/// The index of pixel `(x, y)` in `crop`'s row-major pixels; `None` outside it.
fn crop_index(crop: &PixelRect, x: u32, y: u32) -> Option<usize> {
    let inside = x >= crop.x0 && x < crop.x1 && y >= crop.y0 && y < crop.y1;
    inside.then(|| (y - crop.y0) as usize * crop.width() as usize + (x - crop.x0) as usize)
}

/// The pixels whose samples tile `rect` takes: its own, plus the pixels outside the crop (within the
/// image) that lie within `margin` of the crop and whose nearest crop pixel is in `rect`. Every pixel the
/// filter can reach from the crop is sampled exactly once, so a cropped render equals the same region of
/// the full one.
#[must_use]
pub fn sample_pixels(
    rect: &PixelRect,
    crop: &PixelRect,
    margin: u32,
    format: obscura_sdk::Format,
) -> Vec<(u32, u32)> {
    let x0 = rect
        .x0
        .saturating_sub(if rect.x0 == crop.x0 { margin } else { 0 });
    let y0 = rect
        .y0
        .saturating_sub(if rect.y0 == crop.y0 { margin } else { 0 });
    let x1 = if rect.x1 == crop.x1 {
        (rect.x1 + margin).min(format.width)
    } else {
        rect.x1
    };
    let y1 = if rect.y1 == crop.y1 {
        (rect.y1 + margin).min(format.height)
    } else {
        rect.y1
    };
    let mut out = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
    for y in y0..y1 {
        for x in x0..x1 {
            out.push((x, y));
        }
    }
    out
}

/// Turns one pixel's per-camera-sample hits into deep samples that composite ("over", front to back)
/// to the box-filtered pixel: of the `alive` samples the camera stage kept (culled ones are not
/// part of the pixel, as in the flat film), sample `i` covers `f = 1/alive` of the pixel, so with `F` the coverage in
/// front of it its alpha is `f/(1 − F)` and its colour is premultiplied by the same factor.
#[must_use]
pub fn composite_deep(mut samples: Vec<DeepSample>, alive: u32) -> Vec<DeepSample> {
    samples.sort_by(|a, b| a.z.total_cmp(&b.z));
    let f = 1.0 / alive.max(1) as f32;
    let mut covered = 0.0f32;
    let mut out = Vec::with_capacity(samples.len());
    for s in samples {
        let remaining = (1.0 - covered).max(1e-6);
        let k = (f * s.a / remaining).min(1.0);
        out.push(DeepSample {
            a: k,
            r: s.r * f / remaining,
            g: s.g * f / remaining,
            b: s.b * f / remaining,
            ..s
        });
        covered += f * s.a;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deep_samples_composite_to_the_average_of_the_surviving_samples() {
        let s = |z: f32, v: f32| DeepSample {
            z,
            z_back: z,
            r: v,
            g: v,
            b: v,
            a: 1.0,
        };
        // Four surviving samples, two hit (at different depths), two saw nothing.
        let deep = composite_deep(vec![s(5.0, 1.0), s(2.0, 0.5)], 4);
        let (mut c, mut a) = (0.0f32, 0.0f32);
        for d in &deep {
            c += (1.0 - a) * d.r;
            a += (1.0 - a) * d.a;
        }
        assert!((c - (1.0 + 0.5) / 4.0).abs() < 1e-6, "{c}");
        assert!((a - 0.5).abs() < 1e-6, "{a}");
        assert!(deep[0].z < deep[1].z);
        // Regression: coverage is over the samples the camera stage kept, not the sample count, so a
        // half-culled pixel (a fisheye rim) is as opaque in deep as in the flat film.
        let deep = composite_deep(vec![s(1.0, 1.0), s(1.5, 1.0)], 2);
        let a = deep.iter().fold(0.0f32, |a, d| a + (1.0 - a) * d.a);
        assert!((a - 1.0).abs() < 1e-6);
    }

    #[test]
    fn margins_sample_each_outside_pixel_once() {
        let format = obscura_sdk::Format::new(20, 10);
        let crop = PixelRect {
            x0: 5,
            x1: 15,
            y0: 2,
            y1: 8,
        };
        let mut seen = std::collections::HashMap::new();
        for (x0, y0) in [(5, 2), (10, 2), (5, 5), (10, 5)] {
            let rect = PixelRect {
                x0,
                x1: (x0 + 5).min(15),
                y0,
                y1: (y0 + 3).min(8),
            };
            for p in sample_pixels(&rect, &crop, 2, format) {
                *seen.entry(p).or_insert(0) += 1;
            }
        }
        assert!(seen.values().all(|&n| n == 1));
        assert_eq!(
            seen.len(),
            14 * 10,
            "the crop plus a two-pixel margin, clipped to the image"
        );
    }
}
