"""Camera.rays() against the `obscura rays` EXR, bit for bit (read with the OpenEXR package)."""

import subprocess

import numpy as np
import pytest

import obscura
from conftest import FIXTURES, checker

CHANNELS = {
    "origin": ["origin.X", "origin.Y", "origin.Z"],
    "direction": ["direction.X", "direction.Y", "direction.Z"],
    "origin_radius": ["originRadius"],
    "ray_spread": ["raySpread"],
    "min_dist": ["minDist"],
    "max_dist": ["maxDist"],
    "tint": ["tint.R", "tint.G", "tint.B"],
}


def read_exr(path):
    """Every channel of a float EXR as H×W arrays (data window), with the OpenEXR package."""
    OpenEXR = checker("OpenEXR", "OBSCURA_REQUIRE_INDEPENDENT_EXR")
    part = OpenEXR.File(str(path), separate_channels=True).parts[0]
    return {name: np.asarray(ch.pixels) for name, ch in part.channels.items()}


CASES = [
    ("perspective", ["-p", "PxrPerspective", "--param", "fov=50", "--format", "64x48"],
     lambda: obscura.Camera("PxrPerspective", fov=50, format=(64, 48))),
    ("fisheye-crop", ["-p", "Fisheye", "--param", "mapping=equisolid", "--param", "fov=200",
                      "--format", "60x40", "--crop", "0.1", "0.8", "0.25", "0.9"],
     lambda: obscura.Camera("Fisheye", mapping="equisolid", fov=200, format=(60, 40),
                            crop=(0.1, 0.8, 0.25, 0.9))),
    ("thin-lens", ["-p", "PxrCamera", "--param", "fov=40", "--param", "fStop=2",
                   "--param", "focalLength=0.1", "--param", "focalDistance=4", "--param", "tilt=5",
                   "--format", "40x30", "--clipping", "0.5", "100"],
     lambda: obscura.Camera("PxrCamera", fov=40, fStop=2, focalLength=0.1, focalDistance=4, tilt=5,
                            format=(40, 30), clipping=(0.5, 100))),
    ("colmap", ["--calibration", str(FIXTURES / "cameras.txt"), "--camera", "3", "--format", "80x64"],
     lambda: obscura.Camera.from_calibration(FIXTURES / "cameras.txt", camera=3, format=(80, 64))),
]


@pytest.mark.parametrize("name,args,make", CASES, ids=[c[0] for c in CASES])
def test_rays_equal_obscura_rays_bit_for_bit(obscura_bin, tmp_path, name, args, make):
    out = tmp_path / f"{name}.exr"
    subprocess.run([str(obscura_bin), "rays", *args, "-o", str(out)], check=True, capture_output=True)
    exr = read_exr(out)
    rays = make().rays()
    for key, channels in CHANNELS.items():
        got = rays[key]
        assert got.dtype == np.float32
        want = np.stack([exr[c] for c in channels], axis=-1)
        want = want.reshape(got.shape)
        assert want.dtype == np.float32
        # bit for bit: compare the bytes (inf == inf, and -0.0 differs from 0.0)
        assert np.array_equal(got.view(np.uint32), want.view(np.uint32)), f"{name}: {key} differs"
    assert np.array_equal(rays["valid"], exr["valid"] > 0.5)
