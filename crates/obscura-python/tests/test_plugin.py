"""A C plugin (examples/plugins/c-fisheye) compiled here loads and projects from Python as from the
CLI: its rays follow its documented formula."""

import subprocess

import numpy as np
import pytest

import obscura
from conftest import ROOT


@pytest.fixture(scope="module")
def c_fisheye(tmp_path_factory, c_compiler):
    out = tmp_path_factory.mktemp("plugins") / "CFisheye.so"
    subprocess.run(
        [c_compiler, "-std=c11", "-O2", "-fPIC", "-shared", "-I", str(ROOT / "include"),
         "-o", str(out), str(ROOT / "examples" / "plugins" / "c-fisheye" / "fisheye.c"), "-lm"],
        check=True,
    )
    return out


def test_c_plugin_loads_and_projects(c_fisheye):
    name = obscura.load_plugin(c_fisheye)
    assert name == "CFisheye"
    assert obscura.load_plugin(c_fisheye) == name  # loading again is harmless
    listed = {p["name"]: p for p in obscura.projections()}
    assert listed[name]["path"] and "fov" in {q["name"] for q in listed[name]["params"]}
    cam = obscura.Camera(name, fov=180, format=(64, 64))
    assert cam.dicing_hint == "spherical" and cam.deep_metric == "RayLength"
    rng = np.random.default_rng(0)
    s = rng.uniform(-1.2, 1.2, (5000, 2))
    rays = cam.project(s)
    r = np.hypot(s[:, 0], s[:, 1])
    phi = r * np.radians(180) / 2
    psi = np.arctan2(s[:, 1], s[:, 0])
    want = np.stack([np.sin(phi) * np.cos(psi), np.sin(phi) * np.sin(psi), np.cos(phi)], axis=1)
    inside = r < 1
    assert (rays["valid"] == inside).all()
    assert np.abs(rays["direction"][inside] - want[inside]).max() < 1e-5
    assert (rays["direction"][~inside] == 0).all()
    report = obscura.check(cam)
    assert report["clean"], report


def test_plugin_found_along_plugin_path(c_fisheye):
    obscura.add_plugin_path(c_fisheye.parent)
    cam = obscura.Camera("CFisheye", fov=90)
    assert cam.projection == "CFisheye"


def test_a_missing_plugin_names_where_it_looked(tmp_path):
    with pytest.raises(ValueError, match="NoSuchPlugin"):
        obscura.Camera("NoSuchPlugin")
    bad = tmp_path / "Broken.so"
    bad.write_bytes(b"not a library")
    with pytest.raises(ValueError, match="Broken.so"):
        obscura.load_plugin(bad)
