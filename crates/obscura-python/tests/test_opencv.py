"""ray_to_pixel and pixel_to_ray against OpenCV's own projectPoints (pinhole with 5, 8 and 14
coefficients, fisheye, omnidir), on random points, to 1e-6 px."""

import numpy as np
import pytest

import obscura

TOL = 1e-6
W, H = 1280, 960


def directions(rng, n, max_angle_deg):
    """n random unit directions (OpenCV camera space, +Z forward) within max_angle of the axis,
    at random depths."""
    cos_max = np.cos(np.radians(max_angle_deg))
    z = rng.uniform(cos_max, 1.0, n)
    phi = rng.uniform(-np.pi, np.pi, n)
    s = np.sqrt(1 - z * z)
    d = np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=1)
    return d * rng.uniform(0.5, 20.0, (n, 1))


def compare(cam, points, expected, min_valid=0.95, convention="opencv"):
    """ray_to_pixel of `points` (OpenCV camera space) against OpenCV's pixels `expected`."""
    px, ok = cam.ray_to_pixel(points, pixel_convention=convention, camera_space="opencv")
    assert px.dtype == np.float64 and px.shape == (len(points), 2)
    assert ok.mean() >= min_valid, f"only {ok.mean():.3f} of the points valid"
    err = np.abs(px[ok] - expected[ok]).max()
    assert err < TOL, f"ray_to_pixel differs from OpenCV by {err} px"
    return ok


def inverse_check(cam, pixels, reproject, convention="opencv"):
    """pixel_to_ray of OpenCV's pixels, projected again by OpenCV, lands on the same pixels."""
    d, ok = cam.pixel_to_ray(pixels, pixel_convention=convention, camera_space="opencv")
    assert ok.mean() > 0.95
    np.testing.assert_allclose(np.linalg.norm(d[ok], axis=1), 1.0, atol=1e-12)
    back = reproject(d[ok])
    err = np.abs(back - pixels[ok]).max()
    assert err < TOL, f"pixel_to_ray does not invert OpenCV's projectPoints: {err} px"


def pinhole_camera(dist):
    fx, fy, cx, cy = 700.0, 690.0, 641.3, 478.9
    k = np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1]])
    cam = obscura.Camera(
        "CalibratedCamera",
        model="OPENCV_PINHOLE",
        params=[fx, fy, cx, cy, *dist],
        resolution=(W, H),
    )
    return cam, k


@pytest.mark.parametrize(
    "dist",
    [
        [-0.21, 0.05, 0.0011, -0.0007, -0.004],
        [-0.21, 0.05, 0.0011, -0.0007, -0.004, 0.01, 0.002, 0.0005],
        [-0.21, 0.05, 0.0011, -0.0007, -0.004, 0.01, 0.002, 0.0005, 0.0012, -0.0004, 0.0008, 0.0002, 0.01, -0.008],
    ],
    ids=["k5", "k8", "k14"],
)
def test_pinhole_matches_project_points(cv2, dist):
    rng = np.random.default_rng(len(dist))
    cam, k = pinhole_camera(dist)
    pts = directions(rng, 5000, 40.0)
    zero = np.zeros(3)
    dist_arr = np.array(dist)
    expected = cv2.projectPoints(pts, zero, zero, k, dist_arr)[0].reshape(-1, 2)
    compare(cam, pts, expected)

    def reproject(d):
        return cv2.projectPoints(d, zero, zero, k, dist_arr)[0].reshape(-1, 2)

    inverse_check(cam, expected, reproject)


@pytest.mark.parametrize("model", ["KANNALA_BRANDT", "OPENCV_FISHEYE"])
def test_fisheye_matches_fisheye_project_points(cv2, model):
    rng = np.random.default_rng(7)
    fx, fy, cx, cy = 380.8, 381.5, 639.5, 479.2
    dist = np.array([0.0183, -0.0043, 0.0012, -0.0002])
    k = np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1]])
    # OPENCV_FISHEYE is COLMAP's name for the same formula, in COLMAP's pixel convention (top-left
    # pixel centre at (0.5, 0.5)): the same numbers are the formula's pixels in each model's own
    # convention, which is each camera's default.
    cam = obscura.Camera("CalibratedCamera", model=model, params=[fx, fy, cx, cy, *dist], resolution=(W, H))
    own = cam.pixel_convention
    assert own == {"KANNALA_BRANDT": "opencv", "OPENCV_FISHEYE": "colmap"}[model]
    pts = directions(rng, 5000, 85.0)
    zero = np.zeros((1, 3))

    def project(p):
        return cv2.fisheye.projectPoints(p.reshape(-1, 1, 3), zero, zero, k, dist)[0].reshape(-1, 2)

    expected = project(pts)
    compare(cam, pts, expected, convention=own)
    inverse_check(cam, expected, project, convention=own)


def test_omnidir_with_skew_matches_omnidir_project_points(cv2):
    rng = np.random.default_rng(11)
    fx, fy, cx, cy, s, xi = 560.0, 555.0, 640.2, 481.7, 0.8, 0.9
    dist = np.array([[-0.12, 0.03, 0.0008, -0.0004]])
    k = np.array([[fx, s, cx], [0, fy, cy], [0, 0, 1]])
    cam = obscura.Camera(
        "CalibratedCamera",
        model="OPENCV_OMNIDIR",
        params=[fx, fy, cx, cy, s, xi, *dist[0]],
        resolution=(W, H),
    )
    pts = directions(rng, 5000, 75.0)
    zero = np.zeros((1, 3))

    def project(p):
        out = cv2.omnidir.projectPoints(p.reshape(1, -1, 3), zero, zero, k, xi, dist)[0]
        return out.reshape(-1, 2)

    expected = project(pts)
    compare(cam, pts, expected)
    inverse_check(cam, expected, project)


def test_float32_in_gives_float32_out_close_to_float64(cv2):
    cam, _ = pinhole_camera([-0.21, 0.05, 0.0011, -0.0007, -0.004])
    pts = directions(np.random.default_rng(3), 1000, 40.0)
    p64, ok64 = cam.ray_to_pixel(pts)
    p32, ok32 = cam.ray_to_pixel(pts.astype(np.float32))
    assert p32.dtype == np.float32 and p64.dtype == np.float64
    assert (ok32 == ok64).all()
    assert np.abs(p32[ok32] - p64[ok64]).max() < 1e-3


def test_opencv_calibration_file_matches_project_points(cv2):
    """A camera read from an OpenCV JSON file (with cv2.FileStorage reading the same file for the
    reference): the file's own values, in f64, with OpenCV's pixel convention by default."""
    from conftest import FIXTURES

    path = FIXTURES / "opencv_calibration.json"
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    k = fs.getNode("camera_matrix").mat()
    dist = fs.getNode("distortion_coefficients").mat().ravel()
    cam = obscura.Camera.from_calibration(path)
    assert cam.pixel_convention == "opencv" and cam.format == (640, 480)
    pts = directions(np.random.default_rng(5), 3000, 30.0)
    zero = np.zeros(3)
    expected = cv2.projectPoints(pts, zero, zero, k, dist)[0].reshape(-1, 2)
    px, ok = cam.ray_to_pixel(pts, camera_space="opencv")
    assert ok.mean() > 0.95
    assert np.abs(px[ok] - expected[ok]).max() < TOL
