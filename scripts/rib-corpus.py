#!/usr/bin/env python3
"""Renders every complete RIB scene (one with WorldBegin) under a directory and classifies each.

    scripts/rib-corpus.py DIR [DIR ...] [--obscura PATH] [--jobs N] [--threads N] [--keep] [--csv FILE]

Each scene is rendered by `obscura render SCENE --format 160x120 --spp 4` with its own Display lines,
in a copy of its collection (outputs land beside the copied scenes, never in DIR), with a 60 s wall
clock limit and 2 GiB of address space (prlimit --as). By default one scene at a time on every core,
as a user runs the command; `--jobs N --threads 1` runs N at once for throughput (the 60 s limit
then measures one core). Every outcome is one of:

  rendered   exit 0 and every image written holds more than one colour
  flat       exit 0 but an image is black or one flat colour
  located    a clean error naming the file and line (or a binary request/byte), or a missing file
             or directory
  error      a clean error that names no place
  crash      a panic, a signal, or running out of memory
  timeout    more than 60 s

A scene whose bytes (gzip decompressed) equal an earlier one's, in this or an earlier DIR, counts
once: collections copy each other's examples.

Needs numpy, opencv-python-headless and OpenEXR (PyPI) to look at the images. Prints one line per scene and a
summary; --csv writes the table.
"""

import argparse
import csv
import hashlib
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

LIMIT_SECONDS = 60
LIMIT_BYTES = 2 << 30
ARGS = ["--format", "160x120", "--spp", "4"]


def read_image(path):
    """The image's pixels as a float array (H, W, C), or None when it cannot be read."""
    try:
        if path.lower().endswith(".exr"):
            import OpenEXR

            with OpenEXR.File(path) as f:
                channels = f.channels()
                names = [n for n in ("RGB", "RGBA", "R", "G", "B", "Ci", "Z", "z") if n in channels]
                if not names:
                    names = list(channels)[:1]
                arrays = [np.asarray(channels[n].pixels, dtype=np.float64) for n in names]
                arrays = [a if a.ndim == 3 else a[..., None] for a in arrays]
                return np.concatenate(arrays, axis=2)
        # Any other name (a TIFF named .z, .shd, .pic, …): OpenCV reads by content, floats included.
        import cv2

        img = cv2.imread(path, cv2.IMREAD_UNCHANGED)
        return None if img is None else np.asarray(img, dtype=np.float64)
    except Exception:  # noqa: BLE001 - any unreadable image is "flat" for this count
        return None


def is_flat(img):
    if img is None or img.size == 0:
        return True
    if img.ndim == 2:
        img = img[..., None]
    finite = np.where(np.isfinite(img), img, 0.0)
    spread = finite.reshape(-1, finite.shape[-1]).max(axis=0) - finite.reshape(-1, finite.shape[-1]).min(axis=0)
    return bool(np.all(spread <= 1e-3 * max(1.0, float(np.abs(finite).max()))))


LOCATED = re.compile(
    r"error: .+?(:\d+: |: request \d+ at byte \d+: |: byte \d+: |cannot read|no such file|not found|does not exist)", re.I
)


def run_one(obscura, scene, threads=None):
    """Renders `scene` (in a copied tree) with `threads` threads (None: every core); returns (class,
    seconds, message)."""
    cwd = os.path.dirname(scene)
    cmd = ["prlimit", f"--as={LIMIT_BYTES}", "--", obscura, "render", scene] + ARGS
    if threads is not None:
        cmd += ["--threads", str(threads)]
    start = time.monotonic()
    proc = subprocess.Popen(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        out, err = proc.communicate(timeout=LIMIT_SECONDS)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        return "timeout", time.monotonic() - start, f"over {LIMIT_SECONDS} s"
    seconds = time.monotonic() - start
    out, err = out.decode("utf-8", "replace"), err.decode("utf-8", "replace")
    last = (err.strip().splitlines() or [""])[-1]
    if proc.returncode < 0 or "panicked" in err or "memory allocation" in err:
        return "crash", seconds, last or f"signal {-proc.returncode}"
    if proc.returncode != 0:
        return ("located" if LOCATED.search(last) else "error"), seconds, last
    images = [line[len("wrote "):] for line in out.splitlines() if line.startswith("wrote ")]
    if not images:
        return "flat", seconds, "no image written"
    flat = [p for p in images if is_flat(read_image(p if os.path.isabs(p) else os.path.join(cwd, p)))]
    if flat:
        return "flat", seconds, f"flat: {os.path.basename(flat[0])}"
    return "rendered", seconds, ", ".join(os.path.basename(p) for p in images[:3])


def complete_scenes(root, seen):
    """Every complete scene under `root` whose bytes (decompressed) were not seen before: collections
    copy each other's examples, and a scene counts once."""
    for d, dirs, files in os.walk(root):
        dirs.sort()
        for f in sorted(files):
            if not f.lower().endswith((".rib", ".ribz", ".rib.gz")):
                continue
            p = os.path.join(d, f)
            try:
                with open(p, "rb") as fh:
                    data = fh.read()
                if data[:2] == b"\x1f\x8b":
                    import gzip

                    data = gzip.decompress(data)
            except Exception:  # noqa: BLE001
                continue
            digest = hashlib.sha256(data).digest()
            if b"WorldBegin" in data and digest not in seen:
                seen.add(digest)
                yield p


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--obscura", default=os.path.join(os.path.dirname(__file__), "..", "target", "release", "obscura"))
    ap.add_argument("--jobs", type=int, default=1, help="scenes rendered at once (default 1)")
    ap.add_argument("--threads", type=int, help="--threads for each render (default: every core)")
    ap.add_argument("--csv")
    ap.add_argument("--keep", action="store_true", help="keep the copied trees and their renders")
    a = ap.parse_args()
    obscura = os.path.abspath(a.obscura)
    work = tempfile.mkdtemp(prefix="rib-corpus-")
    scenes = []
    seen = set()
    for i, d in enumerate(a.dirs):
        copy = os.path.join(work, f"{i}-{os.path.basename(os.path.abspath(d))}")
        shutil.copytree(d, copy, symlinks=True)
        scenes += [(os.path.relpath(s, copy), s, d) for s in complete_scenes(copy, seen)]
    rows = []
    with ThreadPoolExecutor(max_workers=a.jobs) as pool:
        for (rel, path, d), (cls, secs, msg) in zip(scenes, pool.map(lambda s: run_one(obscura, s[1], a.threads), scenes)):
            rows.append((d, rel, cls, f"{secs:.1f}", msg))
            print(f"{cls:9} {secs:5.1f}s  {os.path.join(d, rel)}  {msg[:160]}", flush=True)
    counts = {}
    for r in rows:
        counts[r[2]] = counts.get(r[2], 0) + 1
    n = len(rows)
    print(f"\n{n} complete scenes: " + ", ".join(f"{k} {v} ({100 * v / max(n, 1):.0f} %)" for k, v in sorted(counts.items())))
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    print(f"largest resident set of any render: {ru.ru_maxrss / 1024:.0f} MiB")
    if a.csv:
        with open(a.csv, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["collection", "scene", "class", "seconds", "message"])
            w.writerows(rows)
    if not a.keep:
        shutil.rmtree(work, ignore_errors=True)
    else:
        print(f"renders kept in {work}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
