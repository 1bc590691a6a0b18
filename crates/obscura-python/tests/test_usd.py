"""Obscura's USD reader against Pixar's usd-core (PyPI `usd-core`, with OBSCURA_REQUIRE_USD set a
missing one fails): every camera attribute (authored or its schema fallback) and the world transform
at Default and at time codes, to 1e-6 relative, on our own stages and on the shared corpus of public
files (OBSCURA_USD_CORPUS, default /work/shared/corpora/usd; OBSCURA_REQUIRE_CORPORA makes its absence
a failure); and the camera `obscura render --export-usd` writes, read back by usd-core."""

import json
import math
import os
import subprocess
from pathlib import Path

import pytest

from conftest import ROOT, checker

DATA = ROOT / "crates" / "obscura-usd" / "tests" / "data"
CORPUS = Path(os.environ.get("OBSCURA_USD_CORPUS", "/work/shared/corpora/usd"))
SCALARS = [
    "horizontalAperture", "verticalAperture", "horizontalApertureOffset", "verticalApertureOffset",
    "focalLength", "fStop", "focusDistance", "shutter:open", "shutter:close", "exposure",
    "exposure:iso", "exposure:time", "exposure:fStop", "exposure:responsivity",
]
REL = 1e-6


@pytest.fixture(scope="session")
def pxr():
    checker("pxr", "OBSCURA_REQUIRE_USD")
    from pxr import Gf, Usd, UsdGeom  # noqa: F401

    import pxr as module
    return module


def close(a, b, scale=None):
    scale = max(abs(a), abs(b)) if scale is None else scale
    return abs(a - b) <= REL * scale + 1e-12


def ours(obscura_bin, path, times=None):
    args = [str(obscura_bin), "usd-cameras", str(path)]
    for t in times or []:
        args.append(f"--time={float(t)!r}")
    run = subprocess.run(args, capture_output=True, text=True)
    return run


def compare_stage(pxr, obscura_bin, path):
    """Compares every camera of `path`; returns the number of values checked."""
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.Open(str(path))
    if stage.HasAuthoredTimeCodeRange():
        a, b = stage.GetStartTimeCode(), stage.GetEndTimeCode()
        times = [a, a + (b - a) / 4, (a + b) / 2, b]
    else:
        times = [0.0]
    run = ours(obscura_bin, path, times)
    assert run.returncode == 0, f"{path}: {run.stderr}"
    got = json.loads(run.stdout)
    assert got["upAxis"] == UsdGeom.GetStageUpAxis(stage)
    assert close(got["metersPerUnit"], UsdGeom.GetStageMetersPerUnit(stage))
    assert close(got["timeCodesPerSecond"], stage.GetTimeCodesPerSecond())
    expected = [str(p.GetPath()) for p in Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies())
                if p.IsA(UsdGeom.Camera)]
    assert sorted(c["path"] for c in got["cameras"]) == sorted(expected), path
    checked = 0
    for cam in got["cameras"]:
        prim = stage.GetPrimAtPath(cam["path"])
        xf = UsdGeom.Xformable(prim)
        for sample in cam["samples"]:
            t = Usd.TimeCode.Default() if sample["time"] == "default" else Usd.TimeCode(sample["time"])
            where = f"{path} <{cam['path']}> at {sample['time']}"
            attrs = sample["attributes"]
            for name in SCALARS:
                attr = prim.GetAttribute(name)
                want = attr.Get(t) if attr else None
                if want is None:  # an attribute this usd-core's schema does not know
                    continue
                assert close(attrs[name], float(want)), f"{where}: {name} {attrs[name]} != {want}"
                checked += 1
            assert attrs["projection"] == prim.GetAttribute("projection").Get(t), where
            assert attrs["stereoRole"] == prim.GetAttribute("stereoRole").Get(t), where
            near, far = prim.GetAttribute("clippingRange").Get(t)
            assert close(attrs["clippingRange"][0], near) and close(attrs["clippingRange"][1], far), where
            planes = prim.GetAttribute("clippingPlanes").Get(t) or []
            assert len(attrs["clippingPlanes"]) == len(planes), where
            for p, q in zip(attrs["clippingPlanes"], planes):
                assert all(close(a, b) for a, b in zip(p, q)), where
            m = xf.ComputeLocalToWorldTransform(t)
            want = [m[i][j] for i in range(4) for j in range(4)]
            scale = max(1.0, max(abs(v) for v in want))
            for a, b in zip(sample["worldTransform"], want):
                assert close(a, b, scale), f"{where}: world transform {sample['worldTransform']} != {want}"
            checked += 20
    return checked


@pytest.mark.parametrize("path", [DATA / n for n in ("cameras.usda", "lenses.usda", "ri_projection.usda",
                                                      "ri_camera.usda", "instancer.usda")]
                         + [ROOT / "examples" / "usd" / "whip-pan.usda"], ids=lambda p: p.name)
def test_our_stages_match_usd_core(pxr, obscura_bin, path):
    assert compare_stage(pxr, obscura_bin, path) >= 0


def corpus_stages():
    if not CORPUS.is_dir():
        if os.environ.get("OBSCURA_REQUIRE_CORPORA"):
            pytest.fail(f"OBSCURA_REQUIRE_CORPORA is set but {CORPUS} is missing")
        pytest.skip(f"{CORPUS} is not on this machine")
    out = []
    for p in sorted(CORPUS.rglob("*")):
        if p.suffix in (".usda", ".usd", ".usdc", ".usdz") and p.is_file():
            out.append(p)
    return out


def test_corpus_cameras_match_usd_core(pxr, obscura_bin):
    """Every corpus stage that mentions a camera: openusd either opens it and every camera matches
    usd-core, or Obscura refuses it with an error naming the file (never wrong values)."""
    from pxr import Usd, UsdGeom

    matched, refused, checked = 0, [], 0
    for path in corpus_stages():
        stage = Usd.Stage.Open(str(path))
        has_camera = any(p.IsA(UsdGeom.Camera)
                         for p in Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies()))
        if not has_camera:
            continue
        run = ours(obscura_bin, path, [0.0])
        if run.returncode != 0:
            assert str(path) in run.stderr, f"an error that does not name the file: {run.stderr}"
            refused.append(path)
            continue
        checked += compare_stage(pxr, obscura_bin, path)
        matched += 1
    assert matched >= 40, f"only {matched} corpus stages with cameras opened ({len(refused)} refused)"
    assert len(refused) <= matched // 4, [str(p) for p in refused]
    assert checked > 1000


def test_exported_camera_reads_back_in_usd_core(pxr, obscura_bin, tmp_path):
    """The camera of a 3-frame render of cameras.usda, written by --export-usd, read by usd-core: each
    frame's transform equals the source camera's (the same world in Obscura's Y-up axes) and the gate
    gives the same ray at the corners of the image."""
    from pxr import Usd, UsdGeom, Gf

    out = tmp_path / "cam.usda"
    run = subprocess.run(
        [str(obscura_bin), "render", str(DATA / "cameras.usda"), "--frames", "1-3", "--format", "48x32",
         "--spp", "1", "-q", "-o", str(tmp_path / "f.####.exr"), "--export-usd", str(out)],
        capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    exported = Usd.Stage.Open(str(out))
    cam = UsdGeom.Camera(exported.GetPrimAtPath("/ObscuraCamera"))
    assert cam
    source = Usd.Stage.Open(str(DATA / "cameras.usda"))
    src = UsdGeom.Camera(source.GetPrimAtPath("/World/Shot"))
    z_to_y = Gf.Matrix4d().SetRotate(Gf.Rotation(Gf.Vec3d(1, 0, 0), -90))
    for frame in (1, 2, 3):
        t = Usd.TimeCode(frame)
        want = src.ComputeLocalToWorldTransform(t) * z_to_y
        got = cam.ComputeLocalToWorldTransform(t)
        # The shutter opens at -0.25: the exported transform is the camera at shutter open.
        want = src.ComputeLocalToWorldTransform(Usd.TimeCode(frame - 0.25)) * z_to_y
        for i in range(4):
            for j in range(4):
                assert abs(got[i][j] - want[i][j]) <= 1e-5 * max(1, abs(want[i][j])), (frame, got, want)
        # The gate: cropAperture of 36x24 to a 3:2 image keeps it; tangents of the edges agree.
        f_src = src.GetFocalLengthAttr().Get(t)
        f_out = cam.GetFocalLengthAttr().Get(t)
        for a, b in [(cam.GetHorizontalApertureAttr(), 36.0), (cam.GetVerticalApertureAttr(), 24.0),
                     (cam.GetHorizontalApertureOffsetAttr(), 1.5), (cam.GetVerticalApertureOffsetAttr(), -0.75)]:
            assert math.isclose(a.Get(t) / f_out, b / f_src, rel_tol=1e-6), (a.GetName(), frame)
        assert math.isclose(cam.GetFStopAttr().Get(t), 2.8, rel_tol=1e-6)
        assert math.isclose(cam.GetFocusDistanceAttr().Get(t), 12, rel_tol=1e-6)
    near, far = cam.GetClippingRangeAttr().Get()
    assert math.isclose(near, 0.1, rel_tol=1e-6) and math.isclose(far, 500, rel_tol=1e-6)


def test_exported_distorted_camera_carries_its_lens_schema(pxr, obscura_bin, tmp_path):
    from pxr import Usd

    for prim, api, model in [("Pinhole", "OmniLensDistortionOpenCvPinholeAPI", "opencvPinhole"),
                             ("Fisheye", "OmniLensDistortionOpenCvFisheyeAPI", "opencvFisheye"),
                             ("Ftheta", "OmniLensDistortionFthetaAPI", "ftheta")]:
        out = tmp_path / f"{prim}.usda"
        run = subprocess.run(
            [str(obscura_bin), "render", str(DATA / "lenses.usda"), "--camera", prim, "--format", "32x32",
             "--spp", "1", "-q", "-o", str(tmp_path / f"{prim}.exr"), "--export-usd", str(out)],
            capture_output=True, text=True)
        assert run.returncode == 0, run.stderr
        back_stage = Usd.Stage.Open(str(out))
        source_stage = Usd.Stage.Open(str(DATA / "lenses.usda"))
        back = back_stage.GetPrimAtPath("/ObscuraCamera")
        source = source_stage.GetPrimAtPath(f"/Rig/{prim}")
        # usd-core lists only registered schemas as applied; NVIDIA's are read from the metadata.
        assert api in back.GetMetadata("apiSchemas").ApplyOperations([]), back.GetMetadata("apiSchemas")
        names = [a.GetName() for a in source.GetAttributes() if a.GetName().startswith(f"omni:lensdistortion:{model}:")]
        assert names
        for name in names:
            want, got = source.GetAttribute(name).Get(), back.GetAttribute(name).Get()
            if hasattr(want, "__len__"):
                assert all(math.isclose(a, b, rel_tol=1e-6, abs_tol=1e-12) for a, b in zip(got, want)), name
            else:
                assert math.isclose(got, want, rel_tol=1e-6, abs_tol=1e-12), (name, got, want)
