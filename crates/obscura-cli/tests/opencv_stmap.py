"""Independent check of `obscura stmap --from-calibration` with OpenCV's own undistortion maps.

Usage: opencv_stmap.py STMAP.exr MODEL FX FY CX CY WIDTH HEIGHT FOV_DEG COEFF...

The ST-map takes a WIDTH x HEIGHT plate of the calibrated camera (A: K = FX FY CX CY, MODEL
`pinhole` with OpenCV's 4 to 14 coefficients or `fisheye` with Kannala-Brandt's k1..k4) to an
undistorted PxrPerspective image (B) of the same size, whose field of view FOV_DEG spans the image's
smaller side. OpenCV computes the same map with cv2.initUndistortRectifyMap (or its fisheye twin)
-- the forward distortion of every B pixel, no iteration -- given B's pinhole matrix K_B:
f = (min(W, H) / 2) / tan(FOV / 2), principal point at the image centre. Nuke's ST convention: s = (map_x + 0.5) / W, t = 1 - (map_y + 0.5) / H.
Every pixel whose OpenCV source lies inside the plate must be mapped (A = 1) and agree; the others
must be unmapped. Exits non-zero with the worst pixel on any mismatch.
"""

import math
import sys

import cv2
import numpy as np
import OpenEXR

# Plate pixels. The map is f32: s in [0, 1) holds ~6e-8 relative, 4e-5 px at 640 px.
TOLERANCE_PX = 1e-3


def main() -> int:
    path, model = sys.argv[1], sys.argv[2]
    fx, fy, cx, cy = (float(v) for v in sys.argv[3:7])
    width, height = int(sys.argv[7]), int(sys.argv[8])
    fov = math.radians(float(sys.argv[9]))
    coeffs = np.array([float(v) for v in sys.argv[10:]])
    ch = OpenEXR.File(path, separate_channels=True).parts[0].channels
    s, t, a = (ch[c].pixels.astype(np.float64) for c in "RGA")
    if s.shape != (height, width):
        print(f"the map is {s.shape[1]}x{s.shape[0]}, expected {width}x{height}")
        return 1
    k = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
    f_b = (min(width, height) / 2.0) / math.tan(fov / 2.0)
    k_b = np.array([[f_b, 0.0, width / 2.0 - 0.5], [0.0, f_b, height / 2.0 - 0.5], [0.0, 0.0, 1.0]])
    if model == "pinhole":
        maps = cv2.initUndistortRectifyMap(k, coeffs, None, k_b, (width, height), cv2.CV_32FC1)
    elif model == "fisheye":
        maps = cv2.fisheye.initUndistortRectifyMap(k, coeffs, np.eye(3), k_b, (width, height), cv2.CV_32FC1)
    else:
        print(f"unknown model {model!r}")
        return 2
    map_x, map_y = (m.astype(np.float64) for m in maps)
    inside = (map_x > -0.5) & (map_x < width - 0.5) & (map_y > -0.5) & (map_y < height - 0.5)
    mapped = a == 1.0
    # Pixels whose source is within 1e-3 px of the plate's edge may fall either way.
    margin = np.minimum.reduce([map_x + 0.5, width - 0.5 - map_x, map_y + 0.5, height - 0.5 - map_y])
    disagree = (inside != mapped) & (np.abs(margin) > TOLERANCE_PX)
    if disagree.any():
        j, i = np.argwhere(disagree)[0]
        print(f"{disagree.sum()} pixels disagree on being mapped, e.g. {i},{j}: obscura A = {a[j, i]}, "
              f"OpenCV source ({map_x[j, i]:.4f}, {map_y[j, i]:.4f})")
        return 1
    both = inside & mapped
    if both.mean() < 0.5:
        print(f"only {both.sum()} of {both.size} pixels mapped")
        return 1
    got_x = s * width - 0.5
    got_y = (1.0 - t) * height - 0.5
    err = np.where(both, np.maximum(np.abs(got_x - map_x), np.abs(got_y - map_y)), 0.0)
    worst = np.unravel_index(np.argmax(err), err.shape)
    print(f"{both.sum()} pixels mapped, worst |difference| {err.max():.2e} px at {worst[1]},{worst[0]} "
          f"(tolerance {TOLERANCE_PX:.0e})")
    if not err.max() <= TOLERANCE_PX:
        print(f"  obscura ({got_x[worst]}, {got_y[worst]}) opencv ({map_x[worst]}, {map_y[worst]})")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
