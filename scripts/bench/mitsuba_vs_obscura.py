#!/usr/bin/env python3
"""Mitsuba 3's `sample_ray` beside Obscura's `PxrPerspective` `project`, one pinned core, one run.

Requirements (this script installs nothing):

    pip install mitsuba          # PyPI wheel, variant llvm_ad_rgb (needs a system libLLVM)
    cargo build --release -p obscura-projections --example project_rate

Usage:

    python3 scripts/bench/mitsuba_vs_obscura.py [--core 1] [--width 1920 --height 1080] [--rounds 7]

Both sides make the rays of every pixel centre of a 1920x1080 frame (fov 60 across the smaller
side, and for the thin lens f/2.8, 50 mm, focus at 4), on the same core:

- Mitsuba: `sensor.sample_ray` over the whole frame as one wavefront (Dr.Jit's LLVM backend, one
  thread: `dr.set_thread_count(1)`), the screen and aperture samples evaluated beforehand so the
  timed kernel is the ray generation alone; the figure is the best of `--rounds` evaluations.
The two sides alternate `--repeat` times (default 3) and each figure is the best over the repeats,
so a burst of load from other processes on the core does not decide the ratio.

- Obscura: the `project_rate` example (a release binary, started by this script on the same core):
  the same frame in batches of 4096 (the renderer's batch, in L2) and as one batch of the whole
  frame (written to memory like Mitsuba's wavefront), through `project` (40-byte `RtRayGeometry`
  records), through `project_soa` (the same ten fields, 40 bytes a ray, each field its own array)
  and through `project_soa` asked for Mitsuba's fields only (`SoaFields`: direction and max
  distance, 16 bytes a ray; the thin lens adds its origin, 28 bytes). It reports which SIMD tier ran.

What each side stores per ray: Mitsuba's kernel evaluates `ray.o`, `ray.d`, `ray.maxt` and the
weight, but the pinhole's origin and both weights are constants that Dr.Jit keeps as literals, so
it writes direction and maxt: 16 bytes a ray (the thin lens adds its varying origin: 28 bytes).
Obscura's `records` and `SoA` rows write every field of every ray (40 bytes); its `like` rows
write what Mitsuba writes.

Prints Mrays/s per side and the ratio Obscura / Mitsuba, for every repeat and then the best of
each. Benchmarks are not timed tests: this is not part of CI.
"""

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def mitsuba_rates(width, height, rounds):
    import drjit as dr
    import mitsuba as mi

    mi.set_variant("llvm_ad_rgb")
    dr.set_thread_count(1)
    n = width * height
    idx = dr.arange(mi.UInt32, n)
    pos = mi.Point2f((mi.Float(idx % width) + 0.5) / width, (mi.Float(idx // width) + 0.5) / height)
    ap = mi.Point2f(mi.Float((idx * 37) % n) / n, mi.Float((idx * 91) % n) / n)
    dr.eval(pos, ap)
    film = {"type": "hdrfilm", "width": width, "height": height}
    sensors = {
        "pinhole": {"type": "perspective", "fov": 60.0, "fov_axis": "smaller", "near_clip": 0.1,
                    "far_clip": 1e4, "film": film},
        "thin_lens": {"type": "thinlens", "fov": 60.0, "fov_axis": "smaller", "near_clip": 0.1,
                      "far_clip": 1e4, "aperture_radius": 0.5 * 0.05 / 2.8, "focus_distance": 4.0,
                      "film": film},
    }
    rates = {}
    for name, desc in sensors.items():
        sensor = mi.load_dict(desc)
        best = float("inf")
        for r in range(rounds + 1):  # the first round compiles the kernel
            dr.sync_thread()
            t = time.perf_counter()
            ray, weight = sensor.sample_ray(0.0, 0.5, pos, ap)
            dr.eval(ray.o, ray.d, ray.maxt, weight)
            dr.sync_thread()
            if r > 0:
                best = min(best, time.perf_counter() - t)
        rates[name] = n / best / 1e6
    return rates


def obscura_rates(width, height, batch, binary):
    out = subprocess.run(
        [str(binary), "--width", str(width), "--height", str(height), "--batch", str(batch), "--seconds", "2"],
        check=True, capture_output=True, text=True,
    ).stdout
    rates, tier = {}, "?"
    for line in out.splitlines():
        fields = dict(f.split("=", 1) for f in line.split()[1:])
        rates[line.split()[0]] = float(fields["mrays_per_s"])
        tier = fields["tier"]
    return rates, tier


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--core", type=int, default=1, help="the CPU to pin both sides to (default 1)")
    ap.add_argument("--width", type=int, default=1920)
    ap.add_argument("--height", type=int, default=1080)
    ap.add_argument("--rounds", type=int, default=7, help="Mitsuba evaluations per repeat (best kept)")
    ap.add_argument("--repeat", type=int, default=3,
                    help="the two sides alternate this many times; each figure is the best over all repeats")
    ap.add_argument("--binary", type=Path, default=ROOT / "target/release/examples/project_rate",
                    help="the project_rate example (cargo build --release -p obscura-projections --example project_rate)")
    args = ap.parse_args()
    if not args.binary.exists():
        sys.exit(f"{args.binary}: not built; run: cargo build --release -p obscura-projections --example project_rate")
    os.sched_setaffinity(0, {args.core})  # the child inherits the affinity
    try:
        import mitsuba  # noqa: F401
    except ImportError:
        sys.exit("mitsuba is not installed: pip install mitsuba")

    best = lambda a, b: {k: max(a.get(k, 0.0), b[k]) for k in b}  # noqa: E731
    rows = [(m, layout) for layout in ("", "_soa", "_soa_like") for m in ("pinhole", "thin_lens")]
    names = {"": "records", "_soa": "SoA", "_soa_like": "like"}
    ob_batch, mi, ob_frame, tier = {}, {}, {}, "?"

    def table(title, mi, ob_batch, ob_frame):
        print(title)
        print(f"{'model':<10} {'layout':<8} {'Mitsuba':>9} {'Obscura b4096':>14} {'ratio':>6} {'Obscura frame':>14} {'ratio':>6}")
        for model, layout in rows:
            m, b, f = mi[model], ob_batch[model + layout], ob_frame[model + layout]
            name = names[layout]
            print(f"{model:<10} {name:<8} {m:9.1f} {b:14.1f} {b / m:6.2f} {f:14.1f} {f / m:6.2f}")

    for k in range(args.repeat):
        rates, tier = obscura_rates(args.width, args.height, 4096, args.binary)
        mrates = mitsuba_rates(args.width, args.height, args.rounds)
        frates = obscura_rates(args.width, args.height, args.width * args.height, args.binary)[0]
        table(f"repeat {k + 1}", mrates, rates, frates)
        ob_batch, mi, ob_frame = best(ob_batch, rates), best(mi, mrates), best(ob_frame, frates)
    load = os.getloadavg()
    table(f"best of {args.repeat}: one core (cpu {args.core}), {args.width}x{args.height} pixel-centre rays, "
          f"Obscura tier {tier}, load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}", mi, ob_batch, ob_frame)

if __name__ == "__main__":
    main()
