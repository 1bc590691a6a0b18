"""`obscura.render_dataset`: the layout it writes, its resume, its errors, and that it writes the same
bytes as `obscura dataset` (both run the one dataset driver)."""

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest

import obscura

RIG = {
    "schema": "obscura-rig/1",
    "cameras": [
        {"name": "left", "translation": [-0.1, 0, 0]},
        {"name": "right", "translation": [0.1, 0, 0], "projection": "Fisheye", "params": {"fov": 200}},
    ],
}

OPTIONS = dict(
    format=(40, 24), spp=1, annotations=["boxes", "tracks", "correspondences"], tracks=8,
    exports=["colmap", "nerfstudio", "gsplat"],
)
CLI = [
    "--format", "40x24", "--spp", "1", "--annotations", "boxes,tracks,correspondences", "--tracks", "8",
    "--exports", "colmap,nerfstudio,gsplat",
]


def tree(root):
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(Path(root).rglob("*")) if p.is_file()}


def test_render_dataset_writes_the_layout_and_resumes(tmp_path):
    rig = tmp_path / "rig.json"
    rig.write_text(json.dumps(RIG))
    out = tmp_path / "ds"
    s = obscura.render_dataset(None, out, rig=rig, **OPTIONS)
    assert s["finalized"] and sorted(s["rendered"]) == [("left", 1), ("right", 1)]
    manifest = json.loads((out / "dataset.json").read_text())
    assert manifest["layout"] == "obscura-dataset/1"
    assert [c["name"] for c in manifest["cameras"]] == ["left", "right"]
    files = set(manifest["files"])
    on_disk = set(tree(out)) - {"dataset.json"}
    assert files == on_disk
    for f in [
        "images/left/0001.exr",
        "images/right/0001.png",
        "annotations/right/0001.json",
        "tracks/left.npz",
        "correspondences/left__right/0001.npz",
        "correspondences/right__left/0001.npz",
        "colmap/cameras.txt",
        "nerfstudio/left/transforms.json",
        "nerfstudio/right/transforms.json",
        "gsplat/cameras.json",
    ]:
        assert f in files, f
    t = np.load(out / "tracks" / "left.npz")
    n = t["points"].shape[0]
    assert t["points"].shape == (n, 1, 2) and t["status"].shape == (n, 1) and t["local"].shape == (n, 3)
    c = np.load(out / "correspondences" / "left__right" / "0001.npz")
    assert c["target"].shape == (24, 40, 2) and c["status"].shape == (24, 40)
    again = obscura.render_dataset(None, out, rig=rig, **OPTIONS)
    assert again["rendered"] == [] and len(again["skipped"]) == 2


def test_python_and_the_command_write_the_same_bytes(tmp_path, obscura_bin):
    rig = tmp_path / "rig.json"
    rig.write_text(json.dumps(RIG))
    py = tmp_path / "py"
    obscura.render_dataset(None, str(py), rig=str(rig), **OPTIONS)
    cli = tmp_path / "cli"
    subprocess.run([str(obscura_bin), "dataset", "-o", str(cli), "--rig", str(rig), "-q", *CLI], check=True)
    a, b = tree(py), tree(cli)
    assert sorted(a) == sorted(b)
    # The manifest records the options, including the output-independent ones only.
    for name in a:
        assert a[name] == b[name], name


def test_bad_names_and_rig_files_raise_naming_them(tmp_path):
    with pytest.raises(ValueError, match=r"'nerf': unknown name.*colmap, nerfstudio, gsplat"):
        obscura.render_dataset(None, tmp_path / "x", exports="colmap,nerf")
    with pytest.raises(ValueError, match=r"annotations 'box': unknown name; expected one or more of boxes, tracks, correspondences"):
        obscura.render_dataset(None, tmp_path / "x", annotations=["box"])
    bad = tmp_path / "bad.json"
    bad.write_text('{\n "schema": "obscura-rig/1",\n "cameras": [{"name": "a", "rotation": 3}]\n}\n')
    with pytest.raises(ValueError, match=r"bad.json:3: cameras\[0\].rotation: expected a 3x3 matrix"):
        obscura.render_dataset(None, tmp_path / "x", rig=bad)
