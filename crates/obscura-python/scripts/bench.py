"""The Python benchmarks of BENCHMARKS.md ("Python"): `project` on 1 M and 10 M samples against the
Rust references (examples/project_reference.rs: the same projection through the same camera stage's
structure-of-arrays run, on the same samples and threads) in the same run, on 1 and 2 threads;
`ray_to_pixel` against OpenCV's `projectPoints` and pycolmap's `img_from_cam` on the same points.
`project` both into new arrays and into the arrays of an earlier call (`out=`). Best of 3 Python calls in each of 2 interleaved rounds (the Rust references: best of 5 per round,
their modes interleaved). The Rust references:

- *fresh*: the stage's SoA run into fourteen f32 arrays and the valid flags allocated by each call,
  as `project` allocates its numpy arrays;
- *preallocated*: the same into arrays allocated once (no page faults);
- *batch*: the same into one cache-resident 4096-sample chunk per thread (nothing kept);
- *AoS batch*: the array-of-structs stage (`run_prepared`) into a reused batch, the renderer's path.

    cargo build --release -p obscura-python --example project_reference
    python3 crates/obscura-python/scripts/bench.py [project] [ray_to_pixel]
"""

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import obscura

ROOT = Path(__file__).resolve().parents[3]
TARGET = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
REFERENCE = TARGET / "release" / "examples" / "project_reference"

CASES = [
    ("PxrPerspective", {"fov": 60}, []),
    ("Fisheye", {"fov": 180, "mapping": "equisolid"}, ["float fov", "180", "string mapping", "equisolid"]),
    (
        "CalibratedCamera",
        {"model": "OPENCV", "params": [1400, 1400, 960, 540, -0.1, 0.02, 0.001, -0.0005], "resolution": (1920, 1080)},
        ["string model", "OPENCV", "float[] params", "1400 1400 960 540 -0.1 0.02 0.001 -0.0005",
         "int[2] resolution", "1920 1080"],
    ),
]


def best(f, repeat=3):
    t = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        f()
        t = min(t, time.perf_counter() - start)
    return t


def screen_grid(cam, n):
    """The reference's samples: a uniform grid of n points over the screen window."""
    side = int(np.ceil(np.sqrt(n)))
    i = np.arange(n)
    l, r, b, t = cam.screen_window
    x = l + ((i % side) + 0.5) / side * (r - l)
    y = t - ((i // side) + 0.5) / side * (t - b)
    return np.stack([x, y], axis=1).astype(np.float32)


MODES = ["soa", "soa-prealloc", "soa-batch", "batch"]


def reference(name, args, n, threads, modes):
    """Mrays/s of each Rust mode, one process (the modes interleaved inside it)."""
    out = subprocess.run([str(REFERENCE), name, str(n), str(threads), ",".join(modes), *args],
                         check=True, capture_output=True, text=True).stdout
    rates = {}
    for line in out.splitlines():
        if " Mrays/s" in line:
            mode = line.split(": ")[0].split()[-1]
            rates[mode] = float(line.split(": ")[1].split(" Mrays/s")[0])
    return rates


def parts(name, args):
    """The stage's pieces in ns per ray (one thread, one 4096-sample batch)."""
    out = subprocess.run([str(REFERENCE), name, "4096", "1", "parts", *args],
                         check=True, capture_output=True, text=True).stdout
    return next(line for line in out.splitlines() if line.startswith("parts"))


ROUNDS = 2


def project_table():
    print("| projection | N | threads | Python `project` | Python `project(out=)` | Rust SoA, fresh arrays | "
          "Rust SoA, preallocated | Rust SoA, batch only | Rust AoS, batch only | Python / Rust fresh | "
          "Python `out=` / Rust preallocated | Python `out=` / Rust batch only |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name, params, args in CASES:
        cam = obscura.Camera(name, format=(1920, 1080), **params)
        for n in (1_000_000, 10_000_000):
            s = screen_grid(cam, n)
            for threads in (1, 2):
                obscura.set_num_threads(threads)
                # Interleaved rounds, best of each: the machine is shared, so a quiet moment should
                # reach both sides alike.
                py = into = 0.0
                rust = dict.fromkeys(MODES, 0.0)
                out = cam.project(s)
                for _ in range(ROUNDS):
                    py = max(py, n / best(lambda: cam.project(s)) * 1e-6)
                    into = max(into, n / best(lambda: cam.project(s, out=out)) * 1e-6)
                    for mode, rate in reference(name, args, n, threads, MODES).items():
                        rust[mode] = max(rust[mode], rate)
                del out
                fresh, pre, batch, aos = (rust[m] for m in MODES)
                print(f"| `{name}` | {n:,} | {threads} | {py:.1f} | {into:.1f} | {fresh:.1f} | {pre:.1f} | "
                      f"{batch:.1f} | {aos:.1f} | {py / fresh:.0%} | {into / pre:.0%} | {into / batch:.0%} |",
                      flush=True)
    obscura.set_num_threads(0)
    print()
    for name, _, args in CASES:
        print(f"- `{name}`: {parts(name, args)}")


def ray_to_pixel_table():
    import cv2
    import pycolmap

    n = 1_000_000
    rng = np.random.default_rng(0)
    z = rng.uniform(np.cos(np.radians(40)), 1, n)
    phi = rng.uniform(-np.pi, np.pi, n)
    pts = np.stack([np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z], 1) * 5
    fx, fy, cx, cy = 1400.0, 1400.0, 960.0, 540.0
    dist = [-0.1, 0.02, 0.001, -0.0005]
    cam = obscura.Camera("CalibratedCamera", model="OPENCV", params=[fx, fy, cx, cy, *dist],
                         resolution=(1920, 1080))
    ref = pycolmap.Camera(model="OPENCV", width=1920, height=1080, params=[fx, fy, cx, cy, *dist])
    k = np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1]])
    zero = np.zeros(3)
    d = np.array(dist)
    print("| `ray_to_pixel`, 1,000,000 points, OPENCV model | Mpoints/s |")
    print("|---|---:|")
    times = {}
    cv2.setNumThreads(1)
    for _ in range(ROUNDS):
        for threads in (1, 2):
            obscura.set_num_threads(threads)
            key = f"Obscura `ray_to_pixel` (f64), {threads} thread{'s' if threads > 1 else ''}"
            times[key] = min(times.get(key, 1e9), best(lambda: cam.ray_to_pixel(pts, camera_space="opencv")))
        key = f"OpenCV {cv2.__version__} `projectPoints` (1 thread)"
        times[key] = min(times.get(key, 1e9), best(lambda: cv2.projectPoints(pts, zero, zero, k, d)))
        key = f"pycolmap {pycolmap.__version__} `img_from_cam` (1 thread)"
        times[key] = min(times.get(key, 1e9), best(lambda: ref.img_from_cam(pts)))
    obscura.set_num_threads(0)
    for key, t in times.items():
        print(f"| {key} | {n / t * 1e-6:.1f} |")


if __name__ == "__main__":
    if not REFERENCE.exists():
        sys.exit(f"{REFERENCE} is missing: cargo build --release -p obscura-python --example project_reference")
    print(f"obscura {obscura.__version__}, {os.cpu_count()} cores, load average {os.getloadavg()}")
    # `bench.py project` or `bench.py ray_to_pixel` runs one table (the second needs cv2 and pycolmap).
    which = sys.argv[1:] or ["project", "ray_to_pixel"]
    if "project" in which:
        project_table()
        print()
    if "ray_to_pixel" in which:
        ray_to_pixel_table()
