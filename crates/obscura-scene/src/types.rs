//! The scene description: what a reader produces and the renderer consumes.

use std::path::PathBuf;

use std::collections::BTreeMap;

use glam::{Mat4, Vec2, Vec3};
use obscura_host::CameraDesc;
use obscura_sdk::{ParamList, Rgb};

use crate::aov::Aov;
use crate::classic::{BezierPatch, Blobby, Curves, NuPatch, Points};
use crate::texture::{SurfaceMaps, TextureDesc};
use crate::visibility::{ClipPlane, Exposure, Sides, Visibility};

/// A transform that may move during the shutter: motion samples `(time, matrix)`, sorted by time, at
/// least one. Matrices act on column vectors (`p' = M·p`).
#[derive(Debug, Clone, PartialEq)]
pub struct MotionTransform {
    /// `(time in scene units, matrix)`, sorted by time.
    pub samples: Vec<(f32, Mat4)>,
}

impl MotionTransform {
    /// A transform that does not move.
    #[must_use]
    pub fn fixed(m: Mat4) -> Self {
        MotionTransform {
            samples: vec![(0.0, m)],
        }
    }

    /// True when there is more than one distinct sample.
    #[must_use]
    pub fn is_moving(&self) -> bool {
        self.samples.windows(2).any(|w| w[0].1 != w[1].1)
    }
}

impl Default for MotionTransform {
    fn default() -> Self {
        MotionTransform::fixed(Mat4::IDENTITY)
    }
}

/// A triangle mesh (what polygons are triangulated into at load time).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Mesh {
    /// Vertex positions, object space.
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals, if the file gives them (`"N"`).
    pub normals: Option<Vec<Vec3>>,
    /// Triangles, as indices into `positions`.
    pub triangles: Vec<[u32; 3]>,
    /// Texture coordinate sets (`TEXCOORD_0`, `TEXCOORD_1`, … or RIB `st`), each one per position,
    /// as stored in the file (glTF: origin top-left, t down; OBJ and RIB: t up, flipped to glTF's
    /// convention when read so every texture lookup is the same).
    pub uvs: Vec<Vec<Vec2>>,
    /// Linear RGBA vertex colours (`COLOR_0`, OBJ's `v x y z r g b`), one per position.
    pub colors: Option<Vec<[f32; 4]>>,
}

impl Mesh {
    /// A cube of edge `size` centred on the origin (USD's `Cube`): corner `k` at the `k & 1`,
    /// `k >> 1 & 1`, `k >> 2 & 1` ends of x, y and z, each face two triangles wound counter-clockwise
    /// seen from outside.
    #[must_use]
    pub fn cube(size: f32) -> Mesh {
        let h = size / 2.0;
        let positions = (0..8)
            .map(|i| {
                Vec3::new(
                    if i & 1 == 0 { -h } else { h },
                    if i & 2 == 0 { -h } else { h },
                    if i & 4 == 0 { -h } else { h },
                )
            })
            .collect();
        let quads: [[u32; 4]; 6] = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        Mesh {
            positions,
            triangles: quads
                .iter()
                .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
                .collect(),
            ..Mesh::default()
        }
    }
}

/// A Catmull–Clark subdivision control mesh (`SubdivisionMesh "catmull-clark"`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SubdivMesh {
    /// Control-point positions, object space.
    pub positions: Vec<Vec3>,
    /// Vertices per face.
    pub face_counts: Vec<u32>,
    /// Face vertex indices, face after face.
    pub face_indices: Vec<u32>,
    /// Edges tagged `"crease"`: (vertex a, vertex b, sharpness).
    pub creases: Vec<(u32, u32, f32)>,
    /// True when the `"interpolateboundary"` tag is present.
    pub interpolate_boundary: bool,
}

/// A shape in object space, as the RenderMan Interface defines it. Angles in degrees.
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    /// `Sphere radius zmin zmax thetamax`.
    Sphere {
        /// Radius.
        radius: f32,
        /// Lower z cut.
        z_min: f32,
        /// Upper z cut.
        z_max: f32,
        /// Sweep about z, degrees.
        theta_max: f32,
    },
    /// `Cylinder radius zmin zmax thetamax` (open, around z).
    Cylinder {
        /// Radius.
        radius: f32,
        /// Lower z.
        z_min: f32,
        /// Upper z.
        z_max: f32,
        /// Sweep about z, degrees.
        theta_max: f32,
    },
    /// `Cone height radius thetamax` (base on z = 0, apex at z = height).
    Cone {
        /// Height.
        height: f32,
        /// Base radius.
        radius: f32,
        /// Sweep, degrees.
        theta_max: f32,
    },
    /// `Disk height radius thetamax` (at z = height).
    Disk {
        /// z of the disk.
        height: f32,
        /// Radius.
        radius: f32,
        /// Sweep, degrees.
        theta_max: f32,
    },
    /// `Torus majorradius minorradius phimin phimax thetamax`.
    Torus {
        /// Distance from the z axis to the tube centre.
        major_radius: f32,
        /// Tube radius.
        minor_radius: f32,
        /// Start of the tube-angle sweep, degrees.
        phi_min: f32,
        /// End of the tube-angle sweep, degrees.
        phi_max: f32,
        /// Sweep about z, degrees.
        theta_max: f32,
    },
    /// `Hyperboloid x1 y1 z1 x2 y2 z2 thetamax`: the line from `point1` to `point2` swept about z.
    Hyperboloid {
        /// One end of the swept line.
        point1: Vec3,
        /// The other end.
        point2: Vec3,
        /// Sweep about z, degrees.
        theta_max: f32,
    },
    /// `Paraboloid rmax zmin zmax thetamax`: `r = rmax·√(z/zmax)` for `z ∈ [zmin, zmax]`.
    Paraboloid {
        /// Radius at `z_max`.
        radius: f32,
        /// Lower z.
        z_min: f32,
        /// Upper z.
        z_max: f32,
        /// Sweep about z, degrees.
        theta_max: f32,
    },
    /// Bicubic (and bilinear) patches and patch meshes, in Bézier form.
    Patches(Vec<BezierPatch>),
    /// A NURBS patch.
    NuPatch(NuPatch),
    /// Curves, as ribbons.
    Curves(Curves),
    /// Points, as discs facing the camera.
    Points(Points),
    /// An implicit surface of blobs.
    Blobby(Blobby),
    /// Polygons, already triangulated.
    Mesh(Mesh),
    /// A subdivision surface.
    Subdiv(SubdivMesh),
}

/// A surface's material (`Bxdf`). Colours are linear RGB.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Material {
    /// `Bxdf "PxrDiffuse"`: Lambertian, `diffuseColor` (default 0.18).
    Diffuse {
        /// Albedo.
        color: Rgb,
    },
    /// `Bxdf "PxrConstant"`: emits `emitColor` (default 1), unlit.
    Constant {
        /// Emitted radiance.
        color: Rgb,
    },
    /// `Bxdf "PxrSurface"`: a diffuse lobe (`diffuseColor`, `diffuseGain`) plus one GGX specular lobe
    /// (`specularFaceColor` as F0, `specularRoughness`).
    Surface {
        /// Diffuse albedo (colour × gain).
        diffuse: Rgb,
        /// Specular reflectance at normal incidence (Schlick F0).
        specular: Rgb,
        /// GGX roughness in [0, 1] (α = roughness²).
        roughness: f32,
    },
}

impl Default for Material {
    fn default() -> Self {
        Material::Diffuse {
            color: Rgb::new(0.18, 0.18, 0.18),
        }
    }
}

/// How a surface of a classic RenderMan Interface shader (`matte`, `plastic`, `metal`, …) shades
/// beyond its physically based [`Material`]: as the shader's own formula does, by **local
/// illumination**. Its radiance is its emission, plus what its lights give it directly (shadowed as
/// each light says), plus its ambient term, and nothing else: no light reaches it by way of another
/// surface (the standard shaders call only `ambient()`, `diffuse()` and `specular()`; `ambientlight`
/// stands in for the indirect light), so a path ends there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalShading {
    /// The ambient term's reflectance: `Ka·Cs` in the standard shaders' `Cs·(Ka·ambient() + …)`.
    pub ambient: AmbientReflectance,
}

/// The reflectance a classic surface's ambient term multiplies the ambient light `Σ I·C` of the
/// scene's `ambientlight`s by (unshadowed, as the RI's `ambient()`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AmbientReflectance {
    /// A fixed colour: `Ka·Cs`.
    Color(Rgb),
    /// `k` times the diffuse albedo found at the hit, texture included: `paintedplastic`'s
    /// `Ka·Cs·texture(s, t)` = `(Ka/Kd)·(Kd·Cs·texture(s, t))`, with `k = Ka/Kd`.
    DiffuseScaled(f32),
}

/// A light. Intensity is `color · intensity · 2^exposure` (RenderMan's). Each light's `transform` is
/// its light-to-world matrix at shutter open.
#[derive(Debug, Clone, PartialEq)]
pub enum Light {
    /// `PxrDomeLight`: the infinite environment; `lightColorMap` a lat-long image (EXR) or none.
    Dome {
        /// Colour.
        color: Rgb,
        /// Intensity.
        intensity: f32,
        /// Exposure (stops).
        exposure: f32,
        /// Lat-long environment map, if any.
        map: Option<PathBuf>,
        /// Light-to-world.
        transform: Mat4,
    },
    /// `PxrDistantLight`: parallel light along the light's +Z axis, `angleExtent` degrees wide.
    Distant {
        /// Colour.
        color: Rgb,
        /// Intensity.
        intensity: f32,
        /// Exposure (stops).
        exposure: f32,
        /// Apparent angular diameter, degrees (RenderMan default 0.53).
        angle_extent: f32,
        /// `enableShadows`: whether surfaces between a point and the light shadow it (RenderMan's
        /// default 1; off for the classic `distantlight`, whose shader has no shadows).
        enable_shadows: bool,
        /// Light-to-world.
        transform: Mat4,
    },
    /// `PxrRectLight`: a 1×1 square in the light's XY plane centred on the origin, emitting toward +Z.
    Rect {
        /// Colour.
        color: Rgb,
        /// Intensity.
        intensity: f32,
        /// Exposure (stops).
        exposure: f32,
        /// Light-to-world.
        transform: Mat4,
    },
    /// A point light (the classic `pointlight`): irradiance `color · intensity / d²` at distance `d`,
    /// facing it.
    Point(PointEmitter),
    /// A spot light (the classic `spotlight`): a point light whose irradiance is scaled by
    /// `cosⁿ(α) · smoothstep(cos(cone), cos(cone − delta), cos α)`, `α` the angle from `direction`.
    Spot {
        /// Position and strength.
        emitter: PointEmitter,
        /// Unit world-space axis of the beam.
        direction: Vec3,
        /// Half-angle of the cone, radians (`coneangle`).
        cone_angle: f32,
        /// Width of the soft edge inside the cone, radians (`conedeltaangle`).
        cone_delta: f32,
        /// Exponent of the cosine falloff (`beamdistribution`).
        beam_distribution: f32,
    },
    /// Uniform light from every direction (the classic `ambientlight`): radiance
    /// `color · intensity`, not seen by camera rays.
    Ambient {
        /// Colour.
        color: Rgb,
        /// Intensity.
        intensity: f32,
    },
    /// `PxrSphereLight`: a sphere of diameter 1 at the light's origin, emitting outward.
    Sphere {
        /// Colour.
        color: Rgb,
        /// Intensity.
        intensity: f32,
        /// Exposure (stops).
        exposure: f32,
        /// Light-to-world.
        transform: Mat4,
    },
}

/// What [`Light::Point`] and [`Light::Spot`] share: where the light is and how strong.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointEmitter {
    /// Colour.
    pub color: Rgb,
    /// Intensity: the irradiance at distance 1, facing the light, is `color · intensity`.
    pub intensity: f32,
    /// World-space position.
    pub position: Vec3,
    /// Whether surfaces between a point and the light shadow it: off for the classic shaders (the
    /// RI's `pointlight` and `spotlight` have no shadows) unless `Attribute "light" "shadows" "on"`.
    pub enable_shadows: bool,
}

/// One piece of geometry in the world.
#[derive(Debug, Clone, PartialEq)]
pub struct Object {
    /// The shape, object space.
    pub shape: Shape,
    /// Object-to-world, possibly moving.
    pub transform: MotionTransform,
    /// Index into [`Scene::materials`].
    pub material: u32,
    /// `Attribute "dice" "float micropolygonlength"` (default 1 pixel).
    pub micropolygon_length: f32,
    /// Where it was declared (`scene.rib:42`), for messages.
    pub source: String,
    /// Its names for ground truth (ID AOVs, the `.ids.json` sidecar).
    pub identity: Identity,
    /// Which sides camera rays see (RIB `Sides`, `Orientation`; both for glTF and OBJ).
    pub sides: Sides,
    /// Which rays see it at all (RIB `Attribute "visibility"`, BMRT's `"render" "casts_shadows"`).
    pub visibility: Visibility,
}

/// The names an object carries into the ID AOVs: several instances may share one object name (a glTF
/// mesh placed by two nodes, an OBJ group split over materials); each instance is its own.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Identity {
    /// The object's name: RIB `Attribute "identifier" "name"`, a glTF mesh's name, an OBJ object or
    /// group name. Empty when the scene gives none (the renderer then names it by its source).
    pub object: String,
    /// The instance's name: the RIB identifier, a glTF node's name, the OBJ object or group name. Empty
    /// when the scene gives none.
    pub instance: String,
}

/// The pixel filter kinds RenderMan offers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FilterKind {
    /// `"box"`.
    Box,
    /// `"triangle"`.
    Triangle,
    /// `"gaussian"` (the default, 2×2).
    Gaussian,
    /// `"catmull-rom"`.
    CatmullRom,
    /// `"mitchell"`.
    Mitchell,
    /// `"blackman-harris"`.
    BlackmanHarris,
}

/// `PixelFilter "name" xwidth ywidth` (full widths in pixels).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelFilter {
    /// Which filter.
    pub kind: FilterKind,
    /// Full width in x, pixels.
    pub width_x: f32,
    /// Full width in y, pixels.
    pub width_y: f32,
}

impl Default for PixelFilter {
    fn default() -> Self {
        PixelFilter {
            kind: FilterKind::Gaussian,
            width_x: 2.0,
            width_y: 2.0,
        }
    }
}

/// A `Display` driver.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DisplayDriver {
    /// `"openexr"` (also `"exr"`).
    OpenExr,
    /// `"png"`.
    Png,
    /// `"deepexr"`.
    DeepExr,
    /// `"tiff"` (and RenderMan's `"file"`, `"zfile"`, `"shadow"`): baseline TIFF, 8-bit colour or
    /// 32-bit float depth.
    Tiff,
    /// `"dng"`: the sensor's raw mosaic as a DNG file (needs a sensor, [`Scene::sensor`]).
    Dng,
}

/// `Display "file" "driver" "channels"`.
#[derive(Debug, Clone, PartialEq)]
pub struct Display {
    /// Output file.
    pub path: PathBuf,
    /// Driver.
    pub driver: DisplayDriver,
    /// AOVs, in order (`rgbaz` → Ci, Alpha, Z).
    pub aovs: Vec<Aov>,
    /// Write half floats (`"string type" "half"`); EXR only.
    pub half: bool,
}

/// Everything a render needs.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Format, windows, shutter, clipping, camera motion, aperture and shutter opening.
    pub camera: CameraDesc,
    /// The projection's name (`PxrPerspective` when the scene names none).
    pub projection: String,
    /// The projection's parameters as given.
    pub projection_params: ParamList,
    /// Where the file named [`Scene::projection`], for errors about it: `file:line` of the RIB
    /// `Projection` (or `Perspective`) request, `layer: <prim>` of a USD projection prim; `None` for the
    /// default projection and one a reader chose itself.
    pub projection_origin: Option<String>,
    /// The projection declared in the RIB just before [`Scene::projection`] (name and parameters), or
    /// `None` when that one is the first `Projection`. When it is a built-in and [`Scene::projection`]
    /// a plugin, the two are chained as in RenderMan: the built-in fills the rays, then the plugin
    /// edits them (`obscura_host::CameraStage::chained`); otherwise the last `Projection` wins.
    pub projection_base: Option<(String, ParamList)>,
    /// `Hider "raytrace" "int maxsamples"`, or `PixelSamples x y` as `⌈x⌉·⌈y⌉`, whichever came last
    /// (default 64).
    pub samples_per_pixel: u32,
    /// `PixelFilter`.
    pub filter: PixelFilter,
    /// `Display`s; empty means the CLI chooses.
    pub displays: Vec<Display>,
    /// Geometry.
    pub objects: Vec<Object>,
    /// Materials, indexed by [`Object::material`]; index 0 is the default PxrDiffuse.
    pub materials: Vec<Material>,
    /// Lights.
    pub lights: Vec<Light>,
    /// Textures, indexed by [`crate::texture::TextureSlot::texture`].
    pub textures: Vec<TextureDesc>,
    /// Materials whose parameters come from textures, by index into [`Scene::materials`]; such a
    /// material's entry there is its untextured fallback.
    pub material_maps: BTreeMap<u32, SurfaceMaps>,
    /// Set by the glTF and OBJ readers when the file has no camera of its own (or only one that
    /// cannot be used): the world bounds `(min, max)` of its geometry, `[−1, 1]³` when it has none.
    /// The renderer's staging (`obscura_render::staging`) frames them: after reading, as the scene's
    /// own camera, and again for the projection it renders through; it also probes them for an
    /// interior (a room the camera stands inside).
    pub auto_camera: Option<(Vec3, Vec3)>,
    /// True when the file has no light the renderer uses (set by the glTF and OBJ readers, and for a
    /// RIB file by [`crate::load`] and [`crate::load_frames`]): the renderer's staging lights the
    /// scene with its default sky and key light (and a lamp inside a closed interior), ahead of
    /// [`Scene::lights`].
    pub auto_light: bool,
    /// Warnings collected while reading (unknown requests and parameters), each naming file and line.
    pub warnings: Vec<String>,
    /// Seconds of animation the file holds (glTF animations); `None` for a still scene. An animated
    /// scene is posed per frame by its reader ([`crate::gltf_scene::load_gltf_at`]).
    pub animation_seconds: Option<f32>,
    /// `ClippingPlane`s: camera rays do not see geometry on their positive sides.
    pub clip_planes: Vec<ClipPlane>,
    /// `Exposure gain gamma`, applied to the colour of every display.
    pub exposure: Exposure,
    /// The materials that shade by local illumination (the classic shaders'; see [`LocalShading`]),
    /// by index into [`Scene::materials`]. Every other material is path traced.
    pub local_shading: BTreeMap<u32, LocalShading>,
    /// The image sensor after the lens (`Option "sensor"`, `--sensor`): `None` keeps the film's
    /// noiseless linear image as the output.
    pub sensor: Option<obscura_sensor::SensorConfig>,
    /// RIB `Option "searchpath" "string rixplugin"`: directories where projection plugins
    /// (`<Name>.so`) are looked for, after the command line's `--plugin-path` and before
    /// `OBSCURA_PLUGIN_PATH`; relative ones are taken from the RIB file's directory.
    pub plugin_path: Vec<std::path::PathBuf>,
}

impl Scene {
    /// An empty scene for a camera: default projection, 64 samples, gaussian 2×2, one default material.
    #[must_use]
    pub fn new(camera: CameraDesc) -> Self {
        Scene {
            camera,
            projection: "PxrPerspective".into(),
            projection_params: ParamList::new(),
            projection_origin: None,
            projection_base: None,
            samples_per_pixel: 64,
            filter: PixelFilter::default(),
            displays: Vec::new(),
            objects: Vec::new(),
            materials: vec![Material::default()],
            lights: Vec::new(),
            textures: Vec::new(),
            material_maps: BTreeMap::new(),
            auto_camera: None,
            auto_light: false,
            warnings: Vec::new(),
            animation_seconds: None,
            clip_planes: Vec::new(),
            exposure: Exposure::default(),
            local_shading: BTreeMap::new(),
            sensor: None,
            plugin_path: Vec::new(),
        }
    }
}
