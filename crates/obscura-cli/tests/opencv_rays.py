"""Independent check of `obscura rays --calibration` with OpenCV itself (PyPI `opencv-python-headless`).

Usage: opencv_rays.py FILE MODEL FX FY CX CY WIDTH HEIGHT COEFF...

MODEL is `pinhole` (cv2.undistortPoints, 4 to 14 coefficients) or `fisheye` (cv2.fisheye.undistortPoints,
k1..k4). The EXR holds one chief ray per pixel of a frame that the WIDTH x HEIGHT calibration image
spans exactly, in OpenCV's pixel convention (pixel centres at integers). For every pixel, OpenCV
undistorts the calibration pixel under its centre -- run to convergence, not its default five
iterations -- and the ray's normalised point (X/Z, -Y/Z: OpenCV's +Y is down) must agree with it.
Exits non-zero with the worst pixel on any mismatch.
"""

import sys

import cv2
import numpy as np
import OpenEXR

# Normalised-coordinate tolerance: the rays are f32 (~6e-8 relative), OpenCV's solve is converged
# to 1e-14; 2e-6 is about a thousandth of a pixel at these focal lengths.
TOLERANCE = 2e-6


def main() -> int:
    path, model = sys.argv[1], sys.argv[2]
    fx, fy, cx, cy = (float(v) for v in sys.argv[3:7])
    width, height = int(sys.argv[7]), int(sys.argv[8])
    coeffs = np.array([float(v) for v in sys.argv[9:]])
    ch = OpenEXR.File(path, separate_channels=True).parts[0].channels
    d = np.stack([ch[f"direction.{c}"].pixels.astype(np.float64) for c in "XYZ"], axis=-1)
    h, w = d.shape[:2]
    j, i = np.meshgrid(np.arange(h), np.arange(w), indexing="ij")
    u = (i + 0.5) * width / w - 0.5
    v = (j + 0.5) * height / h - 0.5
    pts = np.stack([u, v], axis=-1).reshape(-1, 1, 2)
    k = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
    converge = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 1000, 1e-15)
    if model == "pinhole":
        try:
            want = cv2.undistortPoints(pts, k, coeffs, criteria=converge)
        except (TypeError, cv2.error):
            # OpenCV 4.x names the overload with termination criteria undistortPointsIter.
            want = cv2.undistortPointsIter(pts, k, coeffs, None, None, converge)
    elif model == "fisheye":
        want = cv2.fisheye.undistortPoints(pts, k, coeffs, criteria=converge)
    else:
        print(f"unknown model {model!r}")
        return 2
    want = want.reshape(h, w, 2)
    valid = np.abs(d).sum(axis=-1) > 0
    if valid.mean() < 0.99:
        print(f"only {valid.sum()} of {valid.size} rays are valid")
        return 1
    got = np.stack([d[..., 0] / d[..., 2], -d[..., 1] / d[..., 2]], axis=-1)
    err = np.where(valid, np.abs(got - want).max(axis=-1), 0.0)
    worst = np.unravel_index(np.argmax(err), err.shape)
    print(f"{model}: {valid.sum()} rays, worst |normalised difference| {err.max():.2e} at pixel "
          f"{worst[1]},{worst[0]} (tolerance {TOLERANCE:.0e})")
    if not err.max() <= TOLERANCE:
        print(f"  obscura {got[worst]} opencv {want[worst]}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
