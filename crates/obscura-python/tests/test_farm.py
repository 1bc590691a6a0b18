"""The farm helpers: the frame-list parser is the command line's, and farm.submit writes the job
obscura submit writes (chunks × tiles) for each item."""

import os
import subprocess
from pathlib import Path

import pytest

import obscura
from obscura import farm
from conftest import ROOT


def obscura_bin():
    path = os.environ.get("OBSCURA_BIN")
    if not path:
        pytest.fail("OBSCURA_BIN names the obscura binary (test.sh sets it)")
    return path


def test_parse_frames_reads_what_farms_write():
    assert obscura.parse_frames("1-24:6") == [1, 7, 13, 19]
    assert obscura.parse_frames("1-24x6") == [1, 7, 13, 19]
    assert obscura.parse_frames("1-3,5,7-20:2") == [1, 2, 3, 5, 7, 9, 11, 13, 15, 17, 19]
    assert obscura.parse_frames("-2-1") == [-2, -1, 0, 1]
    assert obscura.frame_chunks("1-24", 6) == ["1-6", "7-12", "13-18", "19-24"]
    with pytest.raises(ValueError, match=r"'1-9:0'.*the step must be at least 1"):
        obscura.parse_frames("1-3,1-9:0")
    with pytest.raises(ValueError, match="at least one frame"):
        obscura.frame_chunks("1-3", 0)


def test_the_cli_reads_the_same_lists():
    # The command line refuses what Python refuses, naming the same item.
    run = subprocess.run([obscura_bin(), "merge", "x.exr", "--frames", "1-3,7:2"], capture_output=True, text=True)
    assert run.returncode == 2 and "'7:2': a step needs a range" in run.stderr
    with pytest.raises(ValueError, match="'7:2': a step needs a range"):
        obscura.parse_frames("1-3,7:2")


def test_submit_writes_one_job_per_item(tmp_path):
    scene = ROOT / "examples" / "animated" / "boxes.gltf"
    items = [
        {"scene": scene, "output": tmp_path / "a" / "rgb.####.exr", "frames": "1-10"},
        {"scene": scene, "output": tmp_path / "b" / "rgb.####.exr", "frames": "1-9:2",
         "render_args": ["--seed", "7"]},
    ]
    jobs = farm.submit(items, engine="slurm", chunk=4, tiles="2x1", render_args=["--spp", "2"],
                       obscura=obscura_bin(), job_root=tmp_path / "jobs", dry_run=True)
    assert [j["render_job"] for j in jobs] == [None, None]
    first, second = (Path(j["job_dir"]) for j in jobs)
    assert first == tmp_path / "jobs" / "job00000"
    assert (first / "chunks.txt").read_text() == "1-4\n5-8\n9-10\n"
    assert (second / "chunks.txt").read_text() == "1-7:2\n9\n"
    assert "TILE_COUNT=2" in (first / "job.env").read_text()
    args = (second / "render.args").read_text().splitlines()
    assert args[1:] == ["-o", str(tmp_path / "b" / "rgb.####.exr"), "--spp", "2", "--seed", "7"]
    assert "--array=0-5" in jobs[0]["output"]  # 3 chunks × 2 tiles
    assert (first / "render.sbatch").read_text() == (ROOT / "scripts/farm/render.sbatch").read_text()
    with pytest.raises(ValueError, match="missing frames"):
        farm.submit([{"scene": scene, "output": "x.exr"}], dry_run=True)
