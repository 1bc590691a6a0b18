#!/usr/bin/env python3
"""Renders every USD layer under a directory and classifies each.

    scripts/usd-corpus.py DIR [--obscura PATH] [--csv FILE] [--timeout S]

Each layer (.usd, .usda, .usdc, .usdz) is rendered by
`obscura render LAYER --frames F --format 96x72 --spp 2 -o OUT.exr` (F: the stage's startTimeCode
when it has a time range, so one image each), in a temporary directory, with a wall clock limit
(default 60 s) and 4 GiB of address space (prlimit --as). The time to open the stage alone is
`obscura usd-cameras LAYER` (open, compose, read every camera). Every outcome is one of:

  rendered   exit 0 and an image written
  located    a clean error naming the layer (a parse failure, a bad value, a stage with no frame)
  error      a clean error that names no file
  crash      a panic, a signal, or running out of memory
  timeout    more than the limit

Prints one line per layer and a summary; --csv writes the table.
"""

import argparse
import csv
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def start_frame(obscura, layer):
    """The first time code of the stage (an int), or None for a still."""
    run = subprocess.run([obscura, "usd-cameras", str(layer), "--time=0"], capture_output=True, text=True)
    if run.returncode != 0:
        return None, run
    info = json.loads(run.stdout)
    r = info.get("timeRange")
    if r and r[0] >= 0:
        return int(math.ceil(r[0])), run
    return None, run


def classify(layer, run, timed_out, out):
    if timed_out:
        return "timeout"
    err = run.stderr
    if run.returncode == 0:
        return "rendered" if any(out.glob("*.exr")) else "error"
    if run.returncode < 0 or "panicked" in err or "memory allocation" in err:
        return "crash"
    if str(layer) in err:
        return "located"
    return "error"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dir")
    ap.add_argument("--obscura", default="target/release/obscura")
    ap.add_argument("--csv")
    ap.add_argument("--timeout", type=float, default=60.0)
    a = ap.parse_args()
    layers = sorted(p for p in Path(a.dir).rglob("*") if p.suffix in (".usd", ".usda", ".usdc", ".usdz") and p.is_file())
    rows = []
    for layer in layers:
        t0 = time.monotonic()
        frame, opened = start_frame(a.obscura, layer)
        t_open = time.monotonic() - t0
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp)
            args = [a.obscura, "render", str(layer), "--format", "96x72", "--spp", "2", "-q", "-o", str(out / "out.exr")]
            if frame is not None:
                args += ["--frames", str(frame)]
            cmd = ["prlimit", f"--as={4 << 30}", "--"] + args
            t0 = time.monotonic()
            timed_out = False
            try:
                run = subprocess.run(cmd, capture_output=True, text=True, timeout=a.timeout)
            except subprocess.TimeoutExpired:
                run, timed_out = None, True
            t_render = time.monotonic() - t0
            kind = classify(layer, run, timed_out, out)
        first = "" if run is None else next((l for l in run.stderr.splitlines() if l.startswith("error")), "")
        first = re.sub(r"/\S*/", "", first)[:160]
        rows.append((str(layer.relative_to(a.dir)), kind, f"{t_open:.2f}", f"{t_render:.2f}", first))
        print(f"{kind:9} open {t_open:6.2f} s  render {t_render:6.2f} s  {layer.relative_to(a.dir)}  {first}", flush=True)
    counts = {}
    for r in rows:
        counts[r[1]] = counts.get(r[1], 0) + 1
    print("summary:", ", ".join(f"{k} {v}" for k, v in sorted(counts.items())), f"of {len(rows)} layers")
    if a.csv:
        with open(a.csv, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["layer", "outcome", "open_s", "render_s", "error"])
            w.writerows(rows)


if __name__ == "__main__":
    sys.exit(main())
