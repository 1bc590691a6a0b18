"""Render datasets and shots on a farm from Python: each item (a scene, its frames, its camera) becomes
the job ``obscura submit`` writes — a Slurm job array over frame chunks × tiles with a collect job
(submitted with ``sbatch``), or the Open Job Description template (run with ``openjd run``) — so a
dataset script does not hand-write cluster code.

>>> from obscura import farm
>>> jobs = farm.submit(
...     [{"scene": "scenes/0001.gltf", "output": "out/0001/rgb.####.exr", "frames": "1-120"},
...      {"scene": "scenes/0002.rib", "output": "out/0002/rgb.####.exr", "frames": "1-120",
...       "render_args": ["--calibration", "cameras.txt", "--camera", "3"]}],
...     engine="slurm", chunk=20, tiles="2x2", render_args=["--spp", "64", "--aov", "all"])
>>> jobs[0]["render_job"], jobs[0]["collect_job"]

The tasks run the ``obscura`` command line (``obscura=`` names it; it must be reachable from the
nodes), whose frame lists are read by the same parser as :func:`obscura.parse_frames`.
"""

import os
import re
import subprocess
from typing import Any, Dict, List, Optional, Sequence, Union

__all__ = ["submit"]

PathLike = Union[str, "os.PathLike[str]"]


def submit(
    items: Sequence[Dict[str, Any]],
    engine: str = "slurm",
    chunk: int = 10,
    tiles: Optional[str] = None,
    render_args: Sequence[str] = (),
    obscura: PathLike = "obscura",
    job_root: Optional[PathLike] = None,
    sbatch_args: Sequence[str] = (),
    openjd: PathLike = "openjd",
    dry_run: bool = False,
) -> List[Dict[str, Any]]:
    """Writes and submits one farm job per item; returns, per item, ``job_dir`` and (Slurm)
    ``render_job`` and ``collect_job`` ids (``None`` with ``dry_run``).

    Each item is a dict with ``scene``, ``output`` (images with a run of ``#`` for the frame number)
    and ``frames`` (``"1-120"``, ``"1-100:5"``, ``"1,5,9"``), and optionally ``render_args`` (a list
    added to ``render_args``: a camera such as ``["--calibration", "cams.txt", "--camera", "3"]``, a
    seed) and ``job_dir``. ``engine`` is ``"slurm"`` or ``"openjd"``; ``chunk`` frames per task;
    ``tiles`` splits each frame (``"2x2"``) and the collect step merges them. Raises ValueError for
    a bad item and RuntimeError, with obscura's message, when writing or submitting fails.
    """
    if engine not in ("slurm", "openjd"):
        raise ValueError(f"engine: expected 'slurm' or 'openjd', got {engine!r}")
    results = []
    for k, item in enumerate(items):
        missing = [key for key in ("scene", "output", "frames") if key not in item]
        if missing:
            raise ValueError(f"item {k}: missing {', '.join(missing)}")
        cmd = [
            os.fspath(obscura), "submit", "--engine", engine, os.fspath(item["scene"]),
            "-o", os.fspath(item["output"]), "--frames", str(item["frames"]), "--chunk", str(int(chunk)),
        ]
        if tiles:
            cmd += ["--tiles", str(tiles)]
        job_dir = item.get("job_dir")
        if job_dir is None and job_root is not None:
            job_dir = os.path.join(os.fspath(job_root), f"job{k:05d}")
        if job_dir is not None:
            cmd += ["--job-dir", os.fspath(job_dir)]
        for a in sbatch_args:
            cmd.append(f"--sbatch-arg={a}")
        if engine == "openjd":
            cmd += ["--openjd", os.fspath(openjd)]
        if dry_run:
            cmd.append("--dry-run")
        extra = list(render_args) + list(item.get("render_args", []))
        if extra:
            cmd += ["--"] + [str(a) for a in extra]
        run = subprocess.run(cmd, capture_output=True, text=True)
        if run.returncode != 0:
            raise RuntimeError(f"item {k} ({item['scene']}): {run.stderr.strip() or run.stdout.strip()}")
        found = re.search(r"^job files in (.*) \(", run.stdout, re.M)
        render = re.search(r"^render job (\S+):", run.stdout, re.M)
        collect = re.search(r"^collect job (\S+) ", run.stdout, re.M)
        results.append({
            "job_dir": found.group(1) if found else None,
            "render_job": render.group(1) if render else None,
            "collect_job": collect.group(1) if collect else None,
            "output": run.stdout,
        })
    return results
