"""Bad input raises a clear Python exception naming the argument or parameter, never a crash."""

import numpy as np
import pytest

import obscura
from conftest import FIXTURES


@pytest.fixture
def cam():
    return obscura.Camera("PxrPerspective", fov=60, format=(64, 48))


def test_unknown_parameter_names_it_and_suggests(cam):
    with pytest.raises(ValueError, match=r'PxrPerspective has no parameter "fvo" \(did you mean "fov"\?\)'):
        obscura.Camera("PxrPerspective", fvo=60)


def test_out_of_range_parameter_says_what_was_expected():
    with pytest.raises(ValueError, match=r'parameter "fov" \(at fov=200\) = 200 is out of range: expected a value in \[0\.001, 180\)'):
        obscura.Camera("PxrPerspective", fov=200)


def test_wrong_parameter_type_raises_type_error():
    with pytest.raises(TypeError, match=r'"fov" \(float fov\) expects a number'):
        obscura.Camera("PxrPerspective", fov="wide")
    with pytest.raises(TypeError, match=r'"mapping" .* expects a str'):
        obscura.Camera("Fisheye", mapping=3)
    with pytest.raises(ValueError, match="mapping"):
        obscura.Camera("Fisheye", mapping="fishy")


def test_unknown_projection_suggests_a_known_one():
    with pytest.raises(ValueError, match="PxrPerspective"):
        obscura.Camera("PxrPerspectve")


def test_bad_camera_options():
    with pytest.raises(ValueError, match="format"):
        obscura.Camera("PxrPerspective", format=(0, 10))
    with pytest.raises(TypeError, match="format"):
        obscura.Camera("PxrPerspective", format="640x480")
    with pytest.raises(ValueError, match="(?i)clipping"):
        obscura.Camera("PxrPerspective", clipping=(5, 1))
    with pytest.raises(ValueError, match="shutter_opening"):
        obscura.Camera("PxrPerspective", shutter_opening=[0, 1])
    with pytest.raises(TypeError, match="world_to_camera"):
        obscura.Camera("PxrPerspective", world_to_camera="identity")


def test_wrong_shape_names_the_argument(cam):
    with pytest.raises(ValueError, match=r"screen: expected an array of shape \(N, 2\), got shape \(5, 3\)"):
        cam.project(np.zeros((5, 3)))
    with pytest.raises(ValueError, match=r"screen: .*got shape \(4,\)"):
        cam.project(np.zeros(4))
    with pytest.raises(ValueError, match="lens: expected 5 rows"):
        cam.project(np.zeros((5, 2)), lens=np.zeros((4, 2)))
    with pytest.raises(ValueError, match=r"time: expected an array of shape \(5,\)"):
        cam.project(np.zeros((5, 2)), time=np.zeros(3))
    with pytest.raises(ValueError, match=r"points: expected an array of shape \(N, 3\)"):
        cam.ray_to_pixel(np.zeros((5, 2)))
    with pytest.raises(ValueError, match=r"px: expected an array of shape \(N, 2\)"):
        cam.pixel_to_ray(np.zeros((2, 5)))


def test_integer_and_other_dtypes_raise_type_error(cam):
    with pytest.raises(TypeError, match="screen: expected a float32 or float64 array, got dtype int64"):
        cam.project(np.zeros((5, 2), dtype=np.int64))
    with pytest.raises(TypeError, match="points: expected a float32 or float64 array"):
        cam.ray_to_pixel(np.ones((5, 3), dtype=np.int32))
    with pytest.raises(TypeError, match="px: expected a float32 or float64 array"):
        cam.pixel_to_ray(np.ones((5, 2), dtype=np.float16))
    with pytest.raises(TypeError, match="screen"):
        cam.project([["a", "b"]])


def test_nan_raises_value_error_naming_argument_and_row(cam):
    s = np.zeros((10, 2))
    s[7, 1] = np.nan
    with pytest.raises(ValueError, match="screen: row 7 is not finite"):
        cam.project(s)
    p = np.ones((10, 3))
    p[3, 0] = np.inf
    with pytest.raises(ValueError, match="points: row 3 is not finite"):
        cam.ray_to_pixel(p)
    with pytest.raises(ValueError, match="time: element 2 is not finite"):
        cam.project(np.zeros((4, 2)), time=np.array([0, 0, np.nan, 0]))


def test_bad_conventions_are_refused(cam):
    with pytest.raises(ValueError, match='pixel_convention="center"' ):
        cam.pixel_to_ray(np.zeros((1, 2)), pixel_convention="center")
    with pytest.raises(ValueError, match='camera_space="ros"' ):
        cam.ray_to_pixel(np.ones((1, 3)), camera_space="ros")


def test_bad_calibration_names_file_and_line():
    with pytest.raises(ValueError, match=r"malformed_cameras.txt:\d+"):
        obscura.Camera.from_calibration(FIXTURES / "malformed_cameras.txt")
    with pytest.raises(ValueError, match="no_such_file"):
        obscura.Camera.from_calibration(FIXTURES / "no_such_file.txt")
    with pytest.raises(ValueError, match="camera"):
        obscura.Camera.from_calibration(FIXTURES / "cameras.txt", camera=99)


def test_bad_calibrated_model_is_refused():
    with pytest.raises(ValueError, match='unknown model "OPENCV_PINHOL"'):
        obscura.Camera("CalibratedCamera", model="OPENCV_PINHOL", params=[1, 1, 1, 1], resolution=(4, 4))
    with pytest.raises(ValueError, match="takes 8 params"):
        obscura.Camera("CalibratedCamera", model="OPENCV", params=[1, 2, 3], resolution=(4, 4))


def test_empty_input_gives_empty_output(cam):
    out = cam.project(np.zeros((0, 2)))
    assert out["direction"].shape == (0, 3) and out["valid"].shape == (0,)
    px, ok = cam.ray_to_pixel(np.zeros((0, 3)))
    assert px.shape == (0, 2) and ok.shape == (0,)


def test_an_int_parameter_beyond_32_bits_is_refused():
    with pytest.raises(ValueError, match="does not fit a 32-bit int"):
        obscura.Camera("CalibratedCamera", model="PINHOLE", params=[1, 1, 1, 1], resolution=(2**40, 4))
