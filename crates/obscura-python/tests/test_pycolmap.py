"""ray_to_pixel and pixel_to_ray against pycolmap's img_from_cam for all 18 COLMAP camera models, on
random points, to 1e-6 px (COLMAP's pixel convention, OpenCV/COLMAP camera space)."""

import numpy as np
import pytest

import obscura

W, H = 640, 480
TOL = 1e-6

# Each model with parameters a real calibration could have, and the largest ray angle (degrees) the
# random points use (inside the model's field of view).
MODELS = {
    "SIMPLE_PINHOLE": ([400.0, 320.0, 240.0], 40),
    "PINHOLE": ([400.0, 410.0, 321.0, 239.0], 40),
    "SIMPLE_RADIAL": ([400.0, 320.0, 240.0, -0.05], 40),
    "RADIAL": ([400.0, 320.0, 240.0, -0.05, 0.01], 40),
    "OPENCV": ([400.0, 410.0, 321.0, 239.0, -0.1, 0.02, 0.001, -0.0005], 40),
    "OPENCV_FISHEYE": ([300.0, 305.0, 320.0, 240.0, 0.02, -0.01, 0.003, -0.0005], 85),
    "FULL_OPENCV": (
        [400.0, 410.0, 320.0, 240.0, -0.1, 0.02, 0.001, -0.0005, 0.001, 0.01, 0.002, 0.0005],
        40,
    ),
    "FOV": ([400.0, 410.0, 320.0, 240.0, 0.8], 40),
    "SIMPLE_RADIAL_FISHEYE": ([300.0, 320.0, 240.0, 0.02], 85),
    "RADIAL_FISHEYE": ([300.0, 320.0, 240.0, 0.02, -0.005], 85),
    "THIN_PRISM_FISHEYE": (
        [300.0, 305.0, 320.0, 240.0, 0.02, -0.01, 0.001, -0.0005, 0.003, -0.0005, 0.0005, -0.0003],
        85,
    ),
    "RAD_TAN_THIN_PRISM_FISHEYE": (
        [300.0, 305.0, 320.0, 240.0, 0.02, -0.01, 0.003, -0.0005, 0.0001, -0.00001,
         0.0005, -0.0003, 0.0004, -0.0002, 0.0003, 0.0001],
        85,
    ),
    "SIMPLE_DIVISION": ([400.0, 320.0, 240.0, -0.1], 40),
    "DIVISION": ([400.0, 410.0, 320.0, 240.0, -0.1], 40),
    "SIMPLE_FISHEYE": ([300.0, 320.0, 240.0], 85),
    "FISHEYE": ([300.0, 305.0, 320.0, 240.0], 85),
    "EUCM": ([300.0, 305.0, 320.0, 240.0, 0.6, 1.1], 85),
    "EQUIRECTANGULAR": ([float(W), float(H)], None),
}


def test_every_colmap_model_is_covered(pycolmap):
    names = {n for n in dir(pycolmap.CameraModelId) if n.isupper() and n != "INVALID"}
    assert names == set(MODELS), names ^ set(MODELS)


def points(rng, n, max_angle):
    if max_angle is None:
        # the sphere, away from the poles (where equirectangular pixels degenerate)
        az = rng.uniform(-np.pi * 0.99, np.pi * 0.99, n)
        el = rng.uniform(-1.4, 1.4, n)
        d = np.stack([np.cos(el) * np.sin(az), -np.sin(el), np.cos(el) * np.cos(az)], axis=1)
    else:
        z = rng.uniform(np.cos(np.radians(max_angle)), 1.0, n)
        phi = rng.uniform(-np.pi, np.pi, n)
        s = np.sqrt(1 - z * z)
        d = np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=1)
    return d * rng.uniform(0.5, 20.0, (n, 1))


@pytest.mark.parametrize("model", list(MODELS))
def test_ray_to_pixel_matches_img_from_cam(pycolmap, model):
    params, max_angle = MODELS[model]
    ref = pycolmap.Camera(model=model, width=W, height=H, params=params)
    cam = obscura.Camera("CalibratedCamera", model=model, params=params, resolution=(W, H))
    assert cam.pixel_convention == "colmap"
    rng = np.random.default_rng(abs(hash(model)) % 2**32)
    pts = points(rng, 4000, max_angle)
    expected = ref.img_from_cam(pts, check_cheirality=False)
    px, ok = cam.ray_to_pixel(pts, camera_space="opencv")
    finite = np.isfinite(expected).all(axis=1)
    assert ok.mean() > 0.95, f"{model}: only {ok.mean():.3f} valid"
    both = ok & finite
    err = np.abs(px[both] - expected[both]).max()
    assert err < TOL, f"{model}: ray_to_pixel differs from pycolmap by {err} px"


@pytest.mark.parametrize("model", list(MODELS))
def test_pixel_to_ray_inverts_img_from_cam(pycolmap, model):
    params, _ = MODELS[model]
    ref = pycolmap.Camera(model=model, width=W, height=H, params=params)
    cam = obscura.Camera("CalibratedCamera", model=model, params=params, resolution=(W, H))
    rng = np.random.default_rng(1 + abs(hash(model)) % 2**32)
    px = rng.uniform([0, 0], [W, H], (4000, 2))
    d, ok = cam.pixel_to_ray(px, camera_space="opencv")
    assert ok.mean() > 0.9, f"{model}: only {ok.mean():.3f} valid"
    assert (d[~ok] == 0).all()
    back = ref.img_from_cam(d[ok], check_cheirality=False)
    err = np.abs(back - px[ok]).max()
    assert err < TOL, f"{model}: pixel_to_ray does not invert pycolmap's img_from_cam: {err} px"


def test_cameras_txt_matches_pycolmap(pycolmap, tmp_path):
    """Every camera of a COLMAP cameras.txt, read by us and by pycolmap's own reader."""
    from conftest import FIXTURES

    path = FIXTURES / "cameras.txt"
    rec_dir = tmp_path / "sparse"
    rec_dir.mkdir()
    (rec_dir / "cameras.txt").write_text(path.read_text())
    (rec_dir / "images.txt").write_text("")
    (rec_dir / "points3D.txt").write_text("")
    rec = pycolmap.Reconstruction(str(rec_dir))
    assert len(rec.cameras) == 4
    rng = np.random.default_rng(2)
    for cam_id, ref in rec.cameras.items():
        cam = obscura.Camera.from_calibration(path, camera=cam_id)
        assert cam.format == (ref.width, ref.height) and cam.model == ref.model_name
        px = rng.uniform([0, 0], [ref.width, ref.height], (2000, 2))
        d, ok = cam.pixel_to_ray(px, camera_space="opencv")
        assert ok.mean() > 0.9
        # COLMAP's fisheye models project through (x/z, y/z): defined in front of the camera only,
        # while camera 3's corners see past 90°.
        ok &= d[:, 2] > 1e-3
        back = ref.img_from_cam(d[ok], check_cheirality=False)
        assert np.abs(back - px[ok]).max() < TOL
