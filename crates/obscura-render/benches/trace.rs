//! Tracing benchmarks for the BVH (`cargo bench -p obscura-render --bench trace`; `scripts/bench-trace.sh`
//! installs the mesh first).
//!
//! The mesh is, in order of preference:
//! 1. the OFF file named by `OBSCURA_BENCH_MESH`;
//! 2. the Stanford bunny, `data/meshes/bunny00.off` inside Debian `libcgal-demo`'s
//!    `/usr/share/doc/libcgal-dev/data.tar.gz` (75,408 triangles), read straight from the tarball;
//! 3. a procedural, noise-displaced geodesic sphere of 103,680 triangles.
//!
//! Rays per second are divan's items per second (one item = one ray), single thread:
//! - `primary_*`: 1024×1024 pinhole rays framing the mesh's bounding sphere;
//! - `incoherent_*`: random origins inside the bounds, uniformly random directions;
//! - `shadow_*`: occlusion rays from every primary hit point to a point light;
//! - `segment_*`: occlusion rays between two random points inside the bounds.
//!
//! `*_mesh` calls [`MeshBvh`] directly (object space, `(t, triangle, u, v)`); `*_scene` goes through
//! [`SceneAccel`] as the renderer does (one instance, full world-space [`Hit`] with normals).
//! `primary_camera*` trace the primary rays as the renderer traces camera rays
//! ([`Tracer::intersect_camera`]): in the same scene (no one-sided instance, no clipping plane: the
//! path every scene without `Sides 1` takes), with the instance one-sided (`Sides 1`), and with a
//! clipping plane through the mesh's centre.

use std::path::Path;
use std::sync::LazyLock;

use divan::Bencher;
use divan::counter::ItemsCount;
use glam::{Affine3A, Vec3A};
use obscura_geometry::bvh::{BvhLayout, Instance, MeshBvh, SceneAccel};
use obscura_geometry::ray::{Ray, Tracer, TriangleMesh};
use obscura_scene::Sides;

const CGAL_DATA: &str = "/usr/share/doc/libcgal-dev/data.tar.gz";
const BUNNY_ENTRY: &str = "data/meshes/bunny00.off";
const IMAGE_SIZE: usize = 1024;
const RANDOM_RAYS: usize = 1 << 20;

fn main() {
    if let Some(path) = std::env::var_os("OBSCURA_TRACE_VS_EMBREE") {
        vs_embree(Path::new(&path));
        return;
    }
    let s = &*SCENE;
    println!(
        "mesh: {} ({} triangles, {} hittable), primary hits {} of {}, shadow rays {}, kernel: {}",
        s.name,
        s.bvh.mesh().len(),
        s.bvh.triangle_count(),
        s.shadow.len(),
        s.primary.len(),
        s.shadow.len(),
        kernel(),
    );
    divan::main();
}

/// The box-test kernel `obscura_geometry::bvh` picks on this CPU.
fn kernel() -> &'static str {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        return "avx2";
    }
    "scalar"
}

struct Scene {
    name: String,
    bvh: MeshBvh,
    accel: SceneAccel,
    /// The same instance, one-sided.
    one_sided: SceneAccel,
    /// The same instance, clipped by a plane through the centre of its bounds.
    clipped: SceneAccel,
    primary: Vec<Ray>,
    incoherent: Vec<Ray>,
    shadow: Vec<Ray>,
    segments: Vec<Ray>,
}

static SCENE: LazyLock<Scene> = LazyLock::new(|| {
    let (name, mesh) = load_mesh();
    let bvh = MeshBvh::build(mesh.clone());
    let placed = || {
        SceneAccel::build(
            vec![mesh.clone()],
            vec![Instance {
                mesh: 0,
                transform: vec![(0.0, Affine3A::IDENTITY)],
            }],
        )
    };
    let accel = placed();
    let one_sided = placed().with_camera_visibility(vec![Sides::Front], &[]);
    let (lo, hi) = bvh.bounds();
    let clipped = placed().with_camera_visibility(vec![], &[((lo + hi) * 0.5, Vec3A::new(0.3, 0.2, 1.0))]);
    let primary = primary_rays(lo, hi);
    let mut rng = SplitMix(0x0b5c_u64);
    let incoherent = (0..RANDOM_RAYS)
        .map(|_| ray(rng.point_in(lo, hi), rng.unit_vector(), f32::INFINITY))
        .collect();
    let segments = (0..RANDOM_RAYS)
        .map(|_| {
            let (a, b) = (rng.point_in(lo, hi), rng.point_in(lo, hi));
            ray(a, (b - a).normalize_or(Vec3A::X), (b - a).length())
        })
        .collect();
    let light = (lo + hi) * 0.5 + Vec3A::new(-1.0, 2.0, 1.5) * (hi - lo).length();
    let shadow = primary
        .iter()
        .filter_map(|r| accel.intersect(r))
        .map(|h| {
            let o = h.position + h.geometric_normal * (1e-4 * (hi - lo).length());
            ray(o, (light - o).normalize(), (light - o).length())
        })
        .collect();
    Scene {
        name,
        bvh,
        accel,
        one_sided,
        clipped,
        primary,
        incoherent,
        shadow,
        segments,
    }
});

fn ray(origin: Vec3A, direction: Vec3A, t_max: f32) -> Ray {
    Ray {
        origin,
        direction,
        t_min: 0.0,
        t_max,
        time: 0.0,
    }
}

/// A pinhole camera in front of the mesh (+z, slightly above) whose view just contains the bounding
/// sphere.
fn primary_rays(lo: Vec3A, hi: Vec3A) -> Vec<Ray> {
    let centre = (lo + hi) * 0.5;
    let radius = (hi - lo).length() * 0.5;
    let back = Vec3A::new(0.0, 0.25, 1.0).normalize();
    let eye = centre + back * (2.5 * radius);
    let half = (1.0 / 2.5f32).asin().tan();
    let right = Vec3A::Y.cross(back).normalize();
    let up = back.cross(right);
    let mut rays = Vec::with_capacity(IMAGE_SIZE * IMAGE_SIZE);
    for y in 0..IMAGE_SIZE {
        for x in 0..IMAGE_SIZE {
            let sx = ((x as f32 + 0.5) / IMAGE_SIZE as f32 * 2.0 - 1.0) * half;
            let sy = (1.0 - (y as f32 + 0.5) / IMAGE_SIZE as f32 * 2.0) * half;
            rays.push(ray(eye, (right * sx + up * sy - back).normalize(), f32::INFINITY));
        }
    }
    rays
}

#[divan::bench(sample_count = 10, sample_size = 1)]
fn build(bencher: Bencher) {
    bencher
        .with_inputs(|| SCENE.bvh.mesh().clone())
        .bench_values(MeshBvh::build);
}

#[divan::bench(sample_count = 10, sample_size = 1)]
fn build_one_thread(bencher: Bencher) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a one-thread pool");
    bencher
        .with_inputs(|| SCENE.bvh.mesh().clone())
        .bench_values(|m| pool.install(|| MeshBvh::build(m)));
}

fn bench_rays(bencher: Bencher, rays: &'static [Ray], trace: impl Fn(&Ray) -> bool + Sync) {
    bencher
        .counter(ItemsCount::new(rays.len()))
        .bench(|| rays.iter().filter(|r| trace(r)).count());
}

#[divan::bench(sample_count = 10, sample_size = 1)]
fn primary_mesh(bencher: Bencher) {
    bench_rays(bencher, &SCENE.primary, |r| SCENE.bvh.intersect(r).is_some());
}

#[divan::bench(sample_count = 10, sample_size = 1)]
fn primary_scene(bencher: Bencher) {
    bench_rays(bencher, &SCENE.primary, |r| SCENE.accel.intersect(r).is_some());
}

#[divan::bench(sample_count = 10, sample_size = 1)]
fn primary_camera(bencher: Bencher) {
    bench_rays(bencher, &SCENE.primary, |r| {
        SCENE.accel.intersect_camera(r).is_some()
    });
}

#[divan::bench(sample_count = 10, sample_size = 1)]
fn primary_camera_one_sided(bencher: Bencher) {
    bench_rays(bencher, &SCENE.primary, |r| {
        SCENE.one_sided.intersect_camera(r).is_some()
    });
}

#[divan::bench(sample_count = 10, sample_size = 1)]
fn primary_camera_clipped(bencher: Bencher) {
    bench_rays(bencher, &SCENE.primary, |r| {
        SCENE.clipped.intersect_camera(r).is_some()
    });
}

#[divan::bench(sample_count = 10, sample_size = 1)]
fn incoherent_mesh(bencher: Bencher) {
    bench_rays(bencher, &SCENE.incoherent, |r| SCENE.bvh.intersect(r).is_some());
}

#[divan::bench(sample_count = 10, sample_size = 1)]
fn incoherent_scene(bencher: Bencher) {
    bench_rays(bencher, &SCENE.incoherent, |r| SCENE.accel.intersect(r).is_some());
}

#[divan::bench(sample_count = 10, sample_size = 1)]
fn shadow_mesh(bencher: Bencher) {
    bench_rays(bencher, &SCENE.shadow, |r| SCENE.bvh.occluded(r));
}

#[divan::bench(sample_count = 10, sample_size = 1)]
fn shadow_scene(bencher: Bencher) {
    bench_rays(bencher, &SCENE.shadow, |r| SCENE.accel.occluded(r));
}

#[divan::bench(sample_count = 10, sample_size = 1)]
fn segment_mesh(bencher: Bencher) {
    bench_rays(bencher, &SCENE.segments, |r| SCENE.bvh.occluded(r));
}

#[divan::bench(sample_count = 10, sample_size = 1)]
fn segment_scene(bencher: Bencher) {
    bench_rays(bencher, &SCENE.segments, |r| SCENE.accel.occluded(r));
}

// ---------------------------------------------------------------------------------------------------
// Side by side with Embree (`scripts/bench/trace_vs_embree.sh`)

/// Passes over a ray set whose fastest is reported.
const PASSES: usize = 5;

/// Times both layouts on the primary, incoherent and shadow rays (fastest of [`PASSES`] passes,
/// this thread only, in the thread's CPU time as `trace_embree` measures too), prints `layout set Mrays/s` lines, and writes the mesh, the rays and the wide
/// BVH's answers to `path` for `bench/embree/trace_embree` (format in `bench/embree/README.md`).
fn vs_embree(path: &Path) {
    let s = &*SCENE;
    let mesh = s.bvh.mesh();
    println!(
        "mesh: {} ({} triangles); rays: primary {}, incoherent {}, shadow {}",
        s.name,
        mesh.triangles.len(),
        s.primary.len(),
        s.incoherent.len(),
        s.shadow.len()
    );
    for layout in [BvhLayout::Binary, BvhLayout::Wide] {
        let start = std::time::Instant::now();
        let bvh = MeshBvh::build_with_layout(mesh.clone(), layout);
        let build = start.elapsed();
        let name = match layout {
            BvhLayout::Binary => "obscura-binary",
            BvhLayout::Wide => "obscura-wide",
        };
        println!(
            "{name} build {:.1} ms memory {:.2} MB",
            build.as_secs_f64() * 1e3,
            bvh.memory_bytes() as f64 / 1e6
        );
        let sets: [(&str, &[Ray], bool); 3] = [
            ("primary", &s.primary, false),
            ("incoherent", &s.incoherent, false),
            ("shadow", &s.shadow, true),
        ];
        for (set, rays, shadow) in sets {
            let best = fastest_trace_pass(&bvh, rays, shadow, PASSES);
            println!("{name} {set} {:.3} Mrays/s", rays.len() as f64 / best / 1e6);
        }
    }
    let bvh = MeshBvh::build(mesh.clone());
    let mut out = Vec::new();
    let mut put = |bytes: &[u8]| out.extend_from_slice(bytes);
    put(b"OBTR\x01\0\0\0");
    put(&(mesh.positions.len() as u32).to_le_bytes());
    put(&(mesh.triangles.len() as u32).to_le_bytes());
    for p in &mesh.positions {
        for c in p.to_array() {
            put(&c.to_le_bytes());
        }
    }
    for t in &mesh.triangles {
        for i in t {
            put(&i.to_le_bytes());
        }
    }
    for (rays, shadow) in [(&s.primary, false), (&s.incoherent, false), (&s.shadow, true)] {
        put(&(rays.len() as u32).to_le_bytes());
        for r in rays.iter() {
            let (t, id) = if shadow {
                (if bvh.occluded(r) { 1.0 } else { 0.0 }, 0)
            } else {
                bvh.intersect(r).map_or((f32::INFINITY, u32::MAX), |h| (h.0, h.1))
            };
            for c in [r.origin.to_array(), r.direction.to_array()].concat() {
                put(&c.to_le_bytes());
            }
            for c in [r.t_min, r.t_max, t] {
                put(&c.to_le_bytes());
            }
            put(&id.to_le_bytes());
        }
    }
    std::fs::write(path, out).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    println!("wrote {}", path.display());
}

include!("../../../bench/thread_clock.rs");

// ---------------------------------------------------------------------------------------------------
// Mesh sources

fn load_mesh() -> (String, TriangleMesh) {
    if let Some(path) = std::env::var_os("OBSCURA_BENCH_MESH") {
        let text = std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("OBSCURA_BENCH_MESH={}: {e}", path.to_string_lossy()));
        let mesh =
            parse_off(&text).unwrap_or_else(|e| panic!("OBSCURA_BENCH_MESH={}: {e}", path.to_string_lossy()));
        return (format!("{} (OBSCURA_BENCH_MESH)", path.to_string_lossy()), mesh);
    }
    match read_tar_gz_entry(Path::new(CGAL_DATA), BUNNY_ENTRY) {
        Ok(bytes) => match parse_off(&String::from_utf8_lossy(&bytes)) {
            Ok(mesh) => return (format!("Stanford bunny, {BUNNY_ENTRY} in {CGAL_DATA}"), mesh),
            Err(e) => println!("{CGAL_DATA}: {BUNNY_ENTRY}: {e}; using the procedural mesh"),
        },
        Err(e) => println!("{CGAL_DATA}: {e} (apt-get install libcgal-demo); using the procedural mesh"),
    }
    (
        "procedural displaced geodesic sphere".to_owned(),
        geodesic_sphere(72),
    )
}

/// A minimal OFF reader: header `OFF`, counts, vertices, then polygons fanned into triangles.
fn parse_off(text: &str) -> Result<TriangleMesh, String> {
    let mut tokens = text
        .lines()
        .map(|l| l.split('#').next().unwrap_or(""))
        .flat_map(str::split_whitespace);
    let header = tokens.next().ok_or("empty file")?;
    if !header.ends_with("OFF") {
        return Err(format!("not an OFF file (header {header:?})"));
    }
    let mut number = |what: &str| -> Result<f64, String> {
        let tok = tokens.next().ok_or_else(|| format!("file ends before {what}"))?;
        tok.parse::<f64>().map_err(|e| format!("{what}: {tok:?}: {e}"))
    };
    let (nv, nf) = (number("vertex count")? as usize, number("face count")? as usize);
    number("edge count")?;
    let mut mesh = TriangleMesh::default();
    for _ in 0..nv {
        let p = [number("x")?, number("y")?, number("z")?];
        mesh.positions
            .push(Vec3A::new(p[0] as f32, p[1] as f32, p[2] as f32));
    }
    for _ in 0..nf {
        let k = number("polygon size")? as usize;
        let idx = (0..k)
            .map(|_| number("vertex index").map(|v| v as u32))
            .collect::<Result<Vec<_>, _>>()?;
        for i in 1..k.saturating_sub(1) {
            mesh.triangles.push([idx[0], idx[i], idx[i + 1]]);
        }
    }
    Ok(mesh)
}

/// One file out of a `.tar.gz`: a gzip header, raw deflate (miniz_oxide), then 512-byte tar records.
fn read_tar_gz_entry(path: &Path, entry: &str) -> Result<Vec<u8>, String> {
    let gz = std::fs::read(path).map_err(|e| e.to_string())?;
    if gz.len() < 18 || gz[0..3] != [0x1f, 0x8b, 8] {
        return Err("not a gzip file".into());
    }
    let flags = gz[3];
    let mut pos = 10;
    if flags & 4 != 0 {
        pos += 2 + usize::from(u16::from_le_bytes([gz[pos], gz[pos + 1]]));
    }
    for bit in [8, 16] {
        if flags & bit != 0 {
            pos += gz[pos..].iter().position(|&b| b == 0).ok_or("bad gzip header")? + 1;
        }
    }
    if flags & 2 != 0 {
        pos += 2;
    }
    let tar = miniz_oxide::inflate::decompress_to_vec(gz.get(pos..).ok_or("bad gzip header")?)
        .map_err(|e| format!("inflate: {e:?}"))?;
    let mut at = 0;
    while at + 512 <= tar.len() && tar[at] != 0 {
        let header = &tar[at..at + 512];
        let field = |r: std::ops::Range<usize>| {
            let f = &header[r];
            String::from_utf8_lossy(&f[..f.iter().position(|&b| b == 0).unwrap_or(f.len())]).into_owned()
        };
        let name = match field(345..500) {
            prefix if !prefix.is_empty() && &header[257..262] == b"ustar" => {
                format!("{prefix}/{}", field(0..100))
            }
            _ => field(0..100),
        };
        let size = usize::from_str_radix(field(124..136).trim(), 8).map_err(|e| format!("tar size: {e}"))?;
        let data = at + 512;
        if name.trim_start_matches("./") == entry {
            return tar
                .get(data..data + size)
                .map(<[u8]>::to_vec)
                .ok_or_else(|| "truncated tar".into());
        }
        at = data + size.div_ceil(512) * 512;
    }
    Err(format!("{entry} not found"))
}

/// An icosahedron with every face split into `f²` triangles, pushed onto a bumpy sphere:
/// `20·f²` triangles.
fn geodesic_sphere(f: u32) -> TriangleMesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let ico = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .map(Vec3A::from_array);
    let faces = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let bump = |p: Vec3A| {
        let n = p.normalize();
        let r = 1.0
            + 0.05 * (7.0 * n.x).sin() * (9.0 * n.y).cos()
            + 0.03 * (23.0 * n.z + 5.0 * n.x).sin()
            + 0.01 * (61.0 * n.y).sin() * (57.0 * n.z).cos();
        n * r
    };
    let mut mesh = TriangleMesh::default();
    for [a, b, c] in faces {
        let (a, b, c) = (ico[a], ico[b], ico[c]);
        let base = mesh.positions.len() as u32;
        // Row i has i + 1 vertices: a + (b - a)·i/f + (c - b)·j/f.
        for i in 0..=f {
            for j in 0..=i {
                let p = a + (b - a) * (i as f32 / f as f32) + (c - b) * (j as f32 / f as f32);
                mesh.positions.push(bump(p));
            }
        }
        let at = |i: u32, j: u32| base + i * (i + 1) / 2 + j;
        for i in 0..f {
            for j in 0..=i {
                mesh.triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                if j < i {
                    mesh.triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
                }
            }
        }
    }
    mesh
}

/// SplitMix64, enough for reproducible benchmark rays.
struct SplitMix(u64);

impl SplitMix {
    fn next_f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }

    fn point_in(&mut self, lo: Vec3A, hi: Vec3A) -> Vec3A {
        lo + (hi - lo) * Vec3A::new(self.next_f32(), self.next_f32(), self.next_f32())
    }

    fn unit_vector(&mut self) -> Vec3A {
        let z = 1.0 - 2.0 * self.next_f32();
        let phi = std::f32::consts::TAU * self.next_f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3A::new(r * phi.cos(), r * phi.sin(), z)
    }
}
