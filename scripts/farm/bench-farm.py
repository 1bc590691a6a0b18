"""Measures what BENCHMARKS.md reports for farms (issue 27), on this machine:

* the bare cost of one task: `obscura render` of one tiny frame (process start, scene load, render);
* the per-task overhead of Slurm (a single-node cluster from slurm-local.sh, 2 CPUs: an array of N
  one-frame tasks and its collect job, from sbatch to the collect job's end) and of `openjd run`
  (N one-frame chunks, one after another);
* one frame in 2x2 tiles (4 processes, 1 thread each, 2 at a time, then `obscura merge`) against one
  process with 2 threads: wall time and total CPU time.

Usage: python3 scripts/farm/bench-farm.py OBSCURA OPENJD   (as root; Slurm from Debian's slurm-wlm)
"""

import os
import resource
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

OBSCURA, OPENJD = os.path.abspath(sys.argv[1]), sys.argv[2]
HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
BOXES = str(ROOT / "examples/animated/boxes.gltf")
CLASSIC = str(ROOT / "examples/scenes/classic.rib")
TINY = ["--format", "16x9", "--spp", "1"]
N = 8


def run(cmd, **kw):
    return subprocess.run(cmd, check=True, capture_output=True, text=True, **kw)


def cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def timed(fn):
    c0, t0 = cpu(), time.perf_counter()
    fn()
    return time.perf_counter() - t0, cpu() - c0


work = Path(tempfile.mkdtemp())
print(f"machine: {os.cpu_count()} CPUs; obscura {OBSCURA}")

# 1. The bare task.
bare = []
for k in range(N):
    (work / "bare").mkdir(exist_ok=True)
    bare.append(timed(lambda: run([OBSCURA, "render", BOXES, "--frames", str(k + 1), *TINY, "-q",
                                   "--camera-json", "-o", str(work / "bare/b.####.exr")]))[0])
bare_s = sum(bare) / len(bare)
print(f"bare task (one 16x9 frame of boxes.gltf, process start + scene load + render): {bare_s * 1000:.0f} ms")

# 2. Slurm.
cluster = work / "cluster"
run([str(HERE / "slurm-local.sh"), "start", str(cluster)])
env = dict(os.environ, SLURM_CONF=str(cluster / "slurm.conf"))
try:
    def slurm_job():
        out = run([OBSCURA, "submit", "--engine", "slurm", BOXES, "-o", str(work / "slurm/b.####.exr"),
                   "--frames", f"1-{N}", "--chunk", "1", "--", *TINY], env=env).stdout
        collect = [l.split()[2] for l in out.splitlines() if l.startswith("collect job ")][0]
        while run(["squeue", "-h", "-j", collect], env=env).stdout.strip():
            time.sleep(0.05)
    wall, _ = timed(slurm_job)
    per_task = wall * 2 / (N + 1)  # 2 CPUs busy; the collect job is a task too
    print(f"Slurm: {N} one-frame tasks + collect in {wall:.2f} s wall: {per_task:.2f} s per task-slot, "
          f"{per_task - bare_s:.2f} s of it scheduling and launch")
finally:
    run([str(HERE / "slurm-local.sh"), "stop", str(cluster)])

# 3. OpenJD.
(work / "openjd").mkdir()
wall, _ = timed(lambda: run([OBSCURA, "submit", "--engine", "openjd", "--openjd", OPENJD, BOXES,
                             "-o", str(work / "openjd/b.####.exr"), "--frames", f"1-{N}", "--chunk", "1", "--", *TINY]))
per_task = wall / (N + 1)
print(f"openjd run: {N} one-frame chunks + collect in {wall:.2f} s wall: {per_task:.2f} s per task, "
      f"{per_task - bare_s:.2f} s of it the session's own")

# 4. Tiles against one process.
frame = ["--format", "480x360", "--spp", "16", "-q"]
(work / "one").mkdir()
(work / "tiles").mkdir()
one = timed(lambda: run([OBSCURA, "render", CLASSIC, *frame, "--threads", "2", "-o", str(work / "one/c.exr")]))
def tiles():
    def tile(i):
        run([OBSCURA, "render", CLASSIC, *frame, "--threads", "1", "--tiles", "2x2", "--tile-index", str(i),
             "-o", str(work / "tiles/c.exr")])
    with ThreadPoolExecutor(2) as pool:
        list(pool.map(tile, range(4)))
    run([OBSCURA, "merge", str(work / "tiles/c.exr"), "--tiles", "2x2", "-q"])
four = timed(tiles)
same = (work / "one/c.exr").read_bytes() == (work / "tiles/c.exr").read_bytes()
print(f"classic.rib 480x360, 16 spp: one process (2 threads) {one[0]:.2f} s wall, {one[1]:.2f} s CPU; "
      f"2x2 tiles (4 processes x 1 thread, 2 at a time) + merge {four[0]:.2f} s wall, {four[1]:.2f} s CPU "
      f"(x{four[0] / one[0]:.2f} wall, x{four[1] / one[1]:.2f} CPU); merged EXR identical: {same}")
subprocess.run(["rm", "-rf", str(work)])
