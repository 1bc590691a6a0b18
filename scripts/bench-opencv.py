#!/usr/bin/env python3
"""OpenCV's undistortPoints on the pixels of `cargo bench -p obscura-calibration --bench models`.

The side-by-side that issue 6 allows: the same OpenCV models with the same parameters, 4096 pixels
spread over the 640x480 calibration image by the same golden-ratio sequence, one thread. Prints, per
model, the rate of OpenCV's default (5 fixed iterations) and of a run to convergence (criteria
COUNT+EPS, 100 iterations, 1e-12), and how far the default lands from the converged result in
normalised coordinates -- the reason Obscura iterates to 1e-9 instead.

OpenCV returns only the undistorted normalised point; Obscura's figures in BENCHMARKS.md are for the
whole ray (direction, analytic ray spread, clipping distances) of each pixel, so the comparison
favours OpenCV.

    python3 -m pip install opencv-python-headless numpy
    python3 scripts/bench-opencv.py
"""

import sys
import time

try:
    import cv2
    import numpy as np
except ImportError:
    sys.exit("needs opencv-python-headless and numpy: python3 -m pip install opencv-python-headless numpy")

BATCH = 4096
W, H = 640, 480

# (label, fx, fy, cx, cy, distortion coefficients in OpenCV's order) -- the bench's cases.
CASES = [
    ("OPENCV", 500.0, 490.0, 322.0, 241.0, [-0.28, 0.07, 0.001, -0.0005]),
    (
        "FULL_OPENCV",
        500.0, 490.0, 322.0, 241.0,
        [-0.28, 0.07, 0.001, -0.0005, -0.002, 0.01, 0.003, 0.0002],
    ),
    (
        "OPENCV_PINHOLE_14",
        500.0, 490.0, 322.0, 241.0,
        [-0.28, 0.07, 0.001, -0.0005, -0.002, 0.01, 0.003, 0.0002, 0.001, -0.0002, 0.0008, 0.0001, 0.01,
         -0.008],
    ),
]


def pixels():
    """The bench's sample positions, as OpenCV pixel coordinates (pixel centres at integers)."""
    i = np.arange(BATCH, dtype=np.float64)
    fx = np.modf(i * 0.618_033_988_75)[0]
    fy = np.modf(i * 0.754_877_666_25)[0]
    return np.stack([fx * W - 0.5, fy * H - 0.5], axis=1).reshape(-1, 1, 2)


def rate(fn, repeat=200):
    """Best of `repeat` timings of `fn`, in millions of points per second."""
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return BATCH / best / 1e6


def undistort(pts, k, d, criteria=None):
    """cv2.undistortPoints, with termination criteria when given (OpenCV 4.x: undistortPointsIter)."""
    if criteria is None:
        return cv2.undistortPoints(pts, k, d)
    try:
        return cv2.undistortPoints(pts, k, d, criteria=criteria)
    except (TypeError, cv2.error):
        return cv2.undistortPointsIter(pts, k, d, None, None, criteria)


def main():
    cv2.setNumThreads(1)
    pts = pixels()
    converge = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)
    print(f"OpenCV {cv2.__version__}, one thread, {BATCH} points per call")
    print(f"{'model':<20} {'default (5 it.)':>17} {'converged':>12} {'default error':>15}")
    for label, fx, fy, cx, cy, dist in CASES:
        k = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
        d = np.array(dist)
        default = undistort(pts, k, d)
        exact = undistort(pts, k, d, converge)
        err = np.abs(default - exact).max()
        r_default = rate(lambda: undistort(pts, k, d))
        r_exact = rate(lambda: undistort(pts, k, d, converge))
        print(f"{label:<20} {r_default:>11.1f} Mpt/s {r_exact:>6.1f} Mpt/s {err:>15.2e}")


if __name__ == "__main__":
    main()
