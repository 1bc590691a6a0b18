"""Independent check of an `obscura rays` file with OpenEXR's own reader (PyPI `OpenEXR`).

Usage: read_rays_exr.py FILE FOV WIDTH HEIGHT [XMIN XMAX YMIN YMAX]

Recomputes every chief ray of PxrPerspective (default screen window, pixel centres) in float64 from
conventions.md and compares it with the file. Exits non-zero with a message on any mismatch.
"""

import math
import sys

import numpy as np
import OpenEXR


def main() -> int:
    path, fov, width, height = sys.argv[1], float(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
    crop = [float(v) for v in sys.argv[5:9]] if len(sys.argv) >= 9 else [0.0, 1.0, 0.0, 1.0]
    part = OpenEXR.File(path, separate_channels=True).parts[0]
    ch = part.channels
    expected = {"origin.X", "origin.Y", "origin.Z", "direction.X", "direction.Y", "direction.Z",
                "originRadius", "raySpread", "tint.R", "tint.G", "tint.B", "valid"}
    missing = expected - set(ch)
    if missing:
        print(f"missing channels: {sorted(missing)}")
        return 1
    if part.header.get("obscura:projection") != "PxrPerspective":
        print(f"projection attribute: {part.header.get('obscura:projection')!r}")
        return 1
    (x0, y0), (x1, y1) = [tuple(int(v) for v in c) for c in part.header["dataWindow"]]
    dw, dh = part.header["displayWindow"]
    if (int(dh[0]) + 1, int(dh[1]) + 1) != (width, height):
        print(f"display window {dw}..{dh}, expected {width}x{height}")
        return 1
    ex0, ex1 = math.ceil(width * crop[0] - 1e-3), math.ceil(width * crop[1] - 1e-3)
    ey0, ey1 = math.ceil(height * crop[2] - 1e-3), math.ceil(height * crop[3] - 1e-3)
    if (x0, y0, x1 + 1, y1 + 1) != (ex0, ey0, ex1, ey1):
        print(f"data window {(x0, y0, x1, y1)}, expected crop pixels {(ex0, ey0, ex1 - 1, ey1 - 1)}")
        return 1

    a = width / height
    left, right, bottom, top = (-a, a, -1.0, 1.0) if a >= 1 else (-1.0, 1.0, -1 / a, 1 / a)
    xs = (np.arange(x0, x1 + 1) + 0.5) / width
    ys = (np.arange(y0, y1 + 1) + 0.5) / height
    sx = left + xs[None, :] * (right - left)
    sy = top - ys[:, None] * (top - bottom)
    d = 1.0 / math.tan(math.radians(fov) / 2)
    length = np.sqrt(sx**2 + sy**2 + d**2)
    want = {"direction.X": sx / length, "direction.Y": sy / length, "direction.Z": d / length + 0 * sx}
    worst = 0.0
    for name, value in want.items():
        got = ch[name].pixels.astype(np.float64)
        worst = max(worst, float(np.max(np.abs(got - value))))
    if worst > 1e-6:
        print(f"directions differ from the closed form by up to {worst}")
        return 1
    for name in ("origin.X", "origin.Y", "origin.Z", "originRadius"):
        if np.any(ch[name].pixels != 0):
            print(f"{name} is not zero for a pinhole")
            return 1
    if not np.all(ch["valid"].pixels == 1) or not np.all(ch["tint.G"].pixels == 1):
        print("valid or tint is not 1 everywhere")
        return 1
    if not np.all(ch["raySpread"].pixels > 0):
        print("raySpread is not positive everywhere")
        return 1
    print(f"ok: {x1 - x0 + 1}x{y1 - y0 + 1} rays agree with the closed form to {worst:.2e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
