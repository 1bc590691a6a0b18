"""The Python API's own promises: shapes, dtypes, memory order, threads, properties, the registry,
stmap, check, render."""

import numpy as np
from pathlib import Path
import pytest

import obscura
from conftest import FIXTURES


def grid(cam):
    """Screen positions of every pixel centre, as rays() samples them."""
    w, h = cam.format
    l, r, b, t = cam.screen_window
    x = l + (np.arange(w) + 0.5) / w * (r - l)
    y = t - (np.arange(h) + 0.5) / h * (t - b)
    xx, yy = np.meshgrid(x, y)
    return np.stack([xx.ravel(), yy.ravel()], axis=1)


def test_project_matches_the_perspective_formula():
    cam = obscura.Camera("PxrPerspective", fov=60, format=(64, 48))
    s = np.random.default_rng(0).uniform(-1.5, 1.5, (1000, 2))
    out = cam.project(s)
    assert set(out) == {"origin", "direction", "origin_radius", "ray_spread", "min_dist", "max_dist",
                        "tint", "time", "valid"}
    assert out["direction"].dtype == np.float64 and out["direction"].shape == (1000, 3)
    d = np.concatenate([s, np.full((1000, 1), 1 / np.tan(np.radians(30)))], axis=1)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    assert np.abs(out["direction"] - d).max() < 1e-6
    assert out["valid"].all() and (out["origin"] == 0).all() and (out["tint"] == 1).all()
    assert cam.fov == pytest.approx(60) and cam.dicing_hint == "perspective"
    assert cam.deep_metric == "CameraZ"


def test_dtypes_and_memory_order():
    cam = obscura.Camera("Fisheye", fov=180, format=(32, 32))
    s = np.random.default_rng(1).uniform(-1, 1, (777, 2))
    c64 = cam.project(s)
    f64 = cam.project(np.asfortranarray(s))
    strided = cam.project(np.repeat(s, 2, axis=1)[:, ::2])  # non-unit column stride
    c32 = cam.project(s.astype(np.float32))
    assert c32["direction"].dtype == np.float32 and c32["valid"].dtype == np.bool_
    for other in (f64, strided):
        for k in c64:
            assert np.array_equal(c64[k], other[k]), k
    # float64 in is rounded to the contract's f32 screen positions: same rays as float32 in
    assert np.array_equal(c64["direction"].astype(np.float32), c32["direction"])
    lists = cam.project(s.tolist())
    assert np.array_equal(lists["direction"], c64["direction"])


def test_threads_do_not_change_the_rays():
    cam = obscura.Camera("PxrCamera", fov=50, fStop=2, focalLength=0.1, focalDistance=3)
    rng = np.random.default_rng(2)
    s, lens, t = rng.uniform(-1, 1, (20000, 2)), rng.uniform(0, 1, (20000, 2)), rng.uniform(0, 1, 20000)
    obscura.set_num_threads(1)
    one = cam.project(s, lens=lens, time=t)
    obscura.set_num_threads(0)
    assert obscura.get_num_threads() >= 1
    many = cam.project(s, lens=lens, time=t)
    for k in one:
        assert np.array_equal(one[k], many[k]), k
    # lens samples move the origins across the aperture (a thin lens), chief rays start at 0
    assert np.abs(one["origin"]).max() > 0
    assert (cam.project(s)["origin"] == 0).all()


def test_rays_are_project_of_the_pixel_centres():
    cam = obscura.Camera("PxrPanini", compression=1, format=(40, 30))
    rays = cam.rays()
    assert rays["direction"].shape == (30, 40, 3) and rays["valid"].shape == (30, 40)
    out = cam.project(grid(cam).astype(np.float32))
    assert np.array_equal(out["direction"], rays["direction"].reshape(-1, 3))


OPENCV = {"model": "OPENCV", "params": [60, 60, 32, 24, -0.1, 0.02, 0.001, -0.0005], "resolution": (64, 48)}


@pytest.mark.parametrize("name,params", [
    ("PxrPerspective", {"fov": 60}),
    ("PxrCamera", {"fov": 50, "fStop": 2, "focalLength": 0.1, "focalDistance": 3}),
    ("Fisheye", {"fov": 180, "mapping": "equisolid"}),
    ("PxrSphereCamera", {}),
    ("PxrPanini", {"compression": 1}),
    ("CalibratedCamera", OPENCV),
])
def test_project_writes_the_camera_stages_rays_field_by_field(name, params):
    """`project` (the stage's structure-of-arrays run, into the numpy arrays) gives `rays()`'s rays
    (the stage's array-of-structs run, the ray map `obscura rays` writes) bit for bit, every field, in
    float32 and float64; each component is contiguous."""
    cam = obscura.Camera(name, format=(64, 48), **params)
    rays = cam.rays()
    n = 64 * 48
    for dtype in (np.float32, np.float64):
        out = cam.project(grid(cam).astype(dtype))
        assert set(out) == set(rays)
        for k in out:
            assert out[k].dtype == (bool if k == "valid" else dtype), k
            assert out[k].shape == ((n, 3) if k in ("origin", "direction", "tint") else (n,)), k
            assert np.array_equal(out[k], rays[k].reshape(out[k].shape)), (name, k, dtype)
        for k in ("origin", "direction", "tint"):
            assert out[k].T.flags.c_contiguous and rays[k].transpose(2, 0, 1).flags.c_contiguous, k
            assert np.array_equal(np.ascontiguousarray(out[k]), out[k])
        assert out["valid"].sum() > 0
        assert np.array_equal(out["valid"], (out["direction"] != 0).any(axis=1))
    if name == "Fisheye":
        assert not out["valid"].all(), "the corners outside the image circle are culled"


def test_float64_and_float32_give_the_same_rays_with_lens_and_time_samples():
    """float64 outputs go through a float32 chunk; float32 ones are written by the stage directly."""
    cam = obscura.Camera("PxrCamera", fov=50, fStop=2, focalLength=0.1, focalDistance=3, format=(64, 48))
    rng = np.random.default_rng(4)
    s, lens, t = rng.uniform(-1, 1, (9000, 2)), rng.uniform(0, 1, (9000, 2)), rng.uniform(0, 1, 9000)
    wide = cam.project(s, lens=lens, time=t)
    narrow = cam.project(s.astype(np.float32), lens=lens.astype(np.float32), time=t.astype(np.float32))
    for k in wide:
        assert np.array_equal(wide[k], narrow[k]), k
    # thin-lens rays from points on the lens meet at the focal distance, where the chief ray does
    chief = cam.project(s)
    at = lambda o: (o["origin"] + o["direction"] * ((3 - o["origin"][:, 2]) / o["direction"][:, 2])[:, None])
    assert np.abs(at(wide) - at(chief)).max() < 1e-4
    assert np.abs(wide["origin"]).max() > 0.01


def test_project_into_the_arrays_of_an_earlier_call():
    cam = obscura.Camera("Fisheye", fov=180, format=(32, 32))
    rng = np.random.default_rng(5)
    a, b = rng.uniform(-1, 1, (5000, 2)), rng.uniform(-1, 1, (5000, 2))
    for dtype in (np.float32, np.float64):
        out = cam.project(a.astype(dtype))
        memory = {k: v.__array_interface__["data"][0] for k, v in out.items()}
        again = cam.project(b.astype(dtype), out=out)
        assert again is out
        assert {k: v.__array_interface__["data"][0] for k, v in out.items()} == memory
        fresh = cam.project(b.astype(dtype))
        for k in fresh:
            assert np.array_equal(out[k], fresh[k]), k
    with pytest.raises(ValueError, match=r'out\["origin"\]: expected a writeable float32 array of shape \(5000, 3\)'):
        cam.project(a.astype(np.float32), out=cam.project(a))  # float64 arrays for float32 samples
    with pytest.raises(ValueError, match=r'out\["tint"\]: .* of shape \(4000, 3\)'):
        cam.project(a[:4000], out={**cam.project(a[:4000]), "tint": np.zeros((4000, 3))})
    with pytest.raises(ValueError, match=r'out: no "valid" array'):
        cam.project(a, out={k: v for k, v in cam.project(a).items() if k != "valid"})
    shared = cam.project(a)
    shared["direction"] = shared["origin"]
    with pytest.raises(ValueError, match="given twice"):
        cam.project(a, out=shared)


def test_crop_gives_the_crop_pixels():
    cam = obscura.Camera("PxrPerspective", format=(100, 50), crop=(0.2, 0.6, 0.0, 0.5))
    assert cam.pixels == (20, 60, 0, 25)
    assert cam.rays()["direction"].shape == (25, 40, 3)


def test_pixel_to_ray_and_back_for_a_projection():
    cam = obscura.Camera("Fisheye", mapping="equidistant", fov=180, format=(200, 200))
    px = np.random.default_rng(3).uniform(0, 200, (3000, 2))
    d, ok = cam.pixel_to_ray(px)
    r = np.hypot(px[:, 0] - 100, px[:, 1] - 100) / 100
    assert (ok == (r < 1)).all()
    back, ok2 = cam.ray_to_pixel(d[ok] * 7.0)
    assert ok2.all()
    assert np.abs(back - px[ok]).max() < 2e-3  # f32 rays
    # the OpenCV pixel convention is the same raster shifted by half a pixel
    back_cv, _ = cam.ray_to_pixel(d[ok], pixel_convention="opencv")
    assert np.allclose(back_cv, back - 0.5)
    # OpenCV camera space flips Y
    d_cv, _ = cam.pixel_to_ray(px, camera_space="opencv")
    assert np.array_equal(d_cv[:, 1], -d[:, 1])


def test_calibrated_camera_convention_defaults_to_the_calibration():
    cam = obscura.Camera.from_calibration(FIXTURES / "cameras.txt", camera=2)
    assert cam.pixel_convention == "colmap" and cam.model == "SIMPLE_RADIAL"
    assert cam.format == (1600, 1200)
    f, cx, cy = 1384.2130466, 800.0, 600.0
    d, ok = cam.pixel_to_ray(np.array([[cx, cy]]))
    assert ok[0] and np.allclose(d[0], [0, 0, 1], atol=1e-12)
    # a resized render keeps the camera: the same ray at the corresponding pixel
    half = obscura.Camera.from_calibration(FIXTURES / "cameras.txt", camera=2, format=(800, 600))
    px = np.array([[100.0, 900.0], [1500.0, 50.0]])
    a, _ = cam.pixel_to_ray(px)
    b, _ = half.pixel_to_ray(px / 2)
    assert np.abs(a - b).max() < 1e-12
    # parameters given as keyword arguments replace the file's
    k0 = obscura.Camera.from_calibration(FIXTURES / "cameras.txt", camera=2, params=[f, cx, cy, 0.0])
    p, _ = k0.ray_to_pixel(np.array([[1.0, 0.0, 2.0]]))
    assert np.allclose(p, [[cx + f / 2, cy]], atol=1e-9)


def test_world_to_pixel_uses_the_camera_transform():
    cam0 = obscura.Camera("PxrPerspective", fov=60, format=(64, 48))
    # RenderMan's row-vector matrices: a translation by (1, 2, 3) sits in the last row
    m = np.eye(4)
    m[3, :3] = [1, 2, 3]
    cam = obscura.Camera("PxrPerspective", fov=60, format=(64, 48), world_to_camera=m)
    p = np.random.default_rng(4).uniform([-1, -1, 2], [1, 1, 5], (100, 3))
    a, oka = cam.world_to_pixel(p)
    b, okb = cam0.ray_to_pixel(p + [1, 2, 3])
    assert (oka == okb).all() and np.allclose(a, b)
    # motion: halfway between two translations
    m2 = m.copy()
    m2[3, :3] = [3, 2, 3]
    moving = obscura.Camera("PxrPerspective", fov=60, world_to_camera=[(0.0, m), (1.0, m2)], shutter=(0, 1))
    assert np.allclose(np.asarray(moving.world_to_camera(0.5))[3, :3], [2, 2, 3], atol=1e-6)


def test_properties_of_a_thin_lens():
    cam = obscura.Camera("PxrCamera", fov=40, fStop=2.8, focalLength=0.05, focalDistance=3)
    assert cam.fstop == pytest.approx(2.8)
    assert cam.focal_length == pytest.approx(0.05) and cam.focal_distance == pytest.approx(3)
    assert cam.params["fStop"] == pytest.approx(2.8)


def test_projections_lists_builtins_with_parameter_tables():
    table = {p["name"]: p for p in obscura.projections()}
    assert {"PxrPerspective", "Fisheye", "CalibratedCamera", "PxrSphereCamera"} <= set(table)
    fov = next(q for q in table["PxrPerspective"]["params"] if q["name"] == "fov")
    assert fov["type"] == "float" and fov["range"] == (0.001, 180)
    assert table["PxrPerspective"]["path"] is None
    models = {m["name"]: m for m in obscura.calibration_models()}
    assert models["OPENCV_OMNIDIR"]["pixel_convention"] == "opencv"
    # The 25 models of COLMAP, OpenCV, Kalibr, OCamCalib, f-theta, … and 3DEqualizer's eight.
    assert len(models) == 33
    assert {"3DE Classic LD Model", "3DE4 Radial - Fisheye, Degree 8"} <= set(models)


def test_check_reports_a_clean_builtin():
    report = obscura.check(obscura.Camera("PxrSphereCamera", hsweep=360, vsweep=180))
    assert report["clean"] and report["projection"] == "PxrSphereCamera"


def test_stmap_of_a_camera_onto_itself_is_the_identity():
    cam = obscura.Camera("Fisheye", fov=180, format=(32, 32))
    m = obscura.stmap(cam, cam)
    assert m["s"].shape == (32, 32)
    x = (np.arange(32) + 0.5) / 32
    ok = m["alpha"] > 0
    assert ok.sum() > 0.7 * 32 * 32
    assert np.abs(m["s"] - x[None, :])[ok].max() < 1e-4
    assert np.abs(m["t"] - (1 - x)[:, None])[ok].max() < 1e-4


def test_render_returns_aovs_and_reports_progress():
    calls = []
    cam = obscura.Camera("PxrPerspective", fov=60, format=(48, 32))
    out = obscura.render(None, camera=cam, spp=2, progress=lambda d, t: calls.append((d, t)))
    assert out["beauty"].shape == (32, 48, 3) and out["z"].shape == (32, 48)
    # The texture AOVs come with the rest: the built-in scene's untextured colours, no coordinates.
    assert out["albedo"].shape == (32, 48, 3) and out["uv"].shape == (32, 48, 2)
    assert out["albedo"].max() > 0 and np.isfinite(out["albedo"]).all() and np.isfinite(out["uv"]).all()
    assert out["alpha"].max() == pytest.approx(1.0) and np.isfinite(out["beauty"]).all()
    assert calls and calls[-1][0] == calls[-1][1] > 0
    only = obscura.render(None, camera=cam, spp=1, aovs=["alpha"])
    assert set(only) == {"alpha", "stats"}
    with pytest.raises(ValueError, match="unknown AOV"):
        obscura.render(None, camera=cam, aovs=["Ci"])
    with pytest.raises(ValueError, match='RenderMan\'s "Ci" is "beauty" here'):
        obscura.render(None, camera=cam, aovs=["Ci"])


def test_render_writes_the_same_files_as_the_command(tmp_path, obscura_bin):
    """Python's render and `obscura render` run one frame pipeline: the same scene and options give
    the same files, byte for byte (EXR with ground truth and flow, PNG preview, ID and camera JSON)."""
    import os
    import subprocess

    aovs = ["cameraZ", "objectId", "flowForward", "flowValid", "albedo"]
    py_dir, cli_dir = tmp_path / "py", tmp_path / "cli"
    py_dir.mkdir()
    cli_dir.mkdir()
    here = os.getcwd()
    os.chdir(py_dir)
    try:
        out = obscura.render(None, spp=2, seed=3, max_depth=3, aovs=aovs, output="out.exr")
    finally:
        os.chdir(here)
    cmd = [str(obscura_bin), "render", "-q", "--spp", "2", "--seed", "3", "--max-depth", "3", "-o", "out.exr"]
    cmd += ["--aov", ",".join(aovs)]
    subprocess.run(cmd, cwd=cli_dir, check=True)
    names = sorted(p.name for p in cli_dir.iterdir())
    assert names == ["out.camera.json", "out.exr", "out.ids.json", "out.png"]
    assert sorted(p.name for p in py_dir.iterdir()) == names
    assert sorted(Path(p).name for p in out["stats"]["written"]) == names
    for name in names:
        assert (py_dir / name).read_bytes() == (cli_dir / name).read_bytes(), name
    # What was written is what was returned: the flow pass ran for the arrays too.
    assert out["flowValid"].shape[2] == 2 and out["flowValid"][..., 0].max() == 1.0
    assert out["objectId"].dtype == np.uint32 and out["objectId"].max() >= 1


def test_render_stops_when_the_progress_callback_raises():
    cam = obscura.Camera("PxrPerspective", format=(256, 256))

    def stop(done, total):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        obscura.render(None, camera=cam, spp=64, progress=stop)


def test_ctrl_c_interrupts_a_render():
    """A real SIGINT while the render runs without the GIL: KeyboardInterrupt, promptly."""
    import os
    import signal
    import threading
    import time

    cam = obscura.Camera("PxrPerspective", format=(512, 512))
    timer = threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT))
    start = time.perf_counter()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            obscura.render(None, camera=cam, spp=256)
    finally:
        timer.cancel()
    assert time.perf_counter() - start < 60
