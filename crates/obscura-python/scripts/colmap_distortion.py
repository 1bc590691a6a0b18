"""The README's worked example: a COLMAP camera's lens distortion as a vector field.

Loads camera 1 of a COLMAP cameras.txt (an OPENCV model, the EuRoC MAV cam0 calibration), gets the
ray of every pixel, and draws where the same camera without distortion would see each ray: the
arrows go from the distorted pixel to the ideal pinhole one. Writes docs/python-colmap-distortion.png.

    python3 -m pip install matplotlib
    python3 crates/obscura-python/scripts/colmap_distortion.py
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import obscura

ROOT = Path(__file__).resolve().parents[3]
cameras_txt = ROOT / "crates" / "obscura-calibration" / "tests" / "fixtures" / "cameras.txt"

cam = obscura.Camera.from_calibration(cameras_txt, camera=1)
w, h = cam.format

# every pixel's chief ray, H×W×3 (float32, bit-identical to `obscura rays`)
field = cam.rays()["direction"]

# the same rays on a coarse grid, in f64 and OpenCV's camera space (+Y down, as COLMAP)
step = 32
u, v = np.meshgrid(np.arange(step / 2, w, step), np.arange(step / 2, h, step))
px = np.stack([u.ravel(), v.ravel()], axis=1)
d, ok = cam.pixel_to_ray(px, camera_space="opencv")

# where an undistorted pinhole with the same intrinsics would see those rays
fx, fy, cx, cy = cam.params["params"][:4]
ideal = np.stack([fx * d[:, 0] / d[:, 2] + cx, fy * d[:, 1] / d[:, 2] + cy], axis=1)
shift = ideal - px

fig, ax = plt.subplots(figsize=(7.52, 5.6), dpi=100)
angle = np.degrees(np.arccos(np.clip(field[..., 2], -1, 1)))
im = ax.imshow(angle, cmap="Greys", extent=(0, w, h, 0))
q = ax.quiver(px[ok, 0], px[ok, 1], shift[ok, 0], shift[ok, 1], np.hypot(*shift[ok].T),
              angles="xy", scale_units="xy", scale=1, cmap="viridis", width=0.003)
fig.colorbar(q, ax=ax, label="distortion (px)", fraction=0.03)
fig.colorbar(im, ax=ax, label="ray angle off the axis (°)", orientation="horizontal", fraction=0.04, pad=0.08)
ax.set_title(f"COLMAP camera 1 ({cam.model}, {w}×{h}): distorted → pinhole pixel")
ax.set_xlim(0, w)
ax.set_ylim(h, 0)
fig.tight_layout()
out = ROOT / "docs" / "python-colmap-distortion.png"
fig.savefig(out)
print(f"wrote {out}: largest shift {np.abs(shift[ok]).max():.1f} px")
