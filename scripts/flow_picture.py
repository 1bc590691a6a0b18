#!/usr/bin/env python3
"""Beauty and optical flow side by side, the flow in the Middlebury colour-wheel coding (Baker et al.,
"A Database and Evaluation Methodology for Optical Flow", 2011: hue = direction, saturation = magnitude
relative to the largest flow; black where flowValid.forward is 0).

    python3 -m pip install OpenEXR numpy pillow
    obscura render examples/animated/boxes.gltf -p Fisheye --param mapping=equidistant \
        --param fov=180 --frames 12 --aov all -o fish.exr --format 320x320 --spp 32
    python3 scripts/flow_picture.py fish.exr docs/flow-fisheye.png
"""
import sys

import numpy as np
import OpenEXR
from PIL import Image


def wheel():
    """The 55 colours of the Middlebury wheel: red-yellow-green-cyan-blue-magenta."""
    segments = [(15, (255, 0, 0), (255, 255, 0)), (6, (255, 255, 0), (0, 255, 0)),
                (4, (0, 255, 0), (0, 255, 255)), (11, (0, 255, 255), (0, 0, 255)),
                (13, (0, 0, 255), (255, 0, 255)), (6, (255, 0, 255), (255, 0, 0))]
    cols = []
    for n, a, b in segments:
        for i in range(n):
            f = i / n
            cols.append([a[k] + (b[k] - a[k]) * f for k in range(3)])
    return np.array(cols) / 255.0


def flow_to_rgb(u, v, valid):
    mag = np.hypot(u, v)
    top = max(np.max(mag[valid > 0]) if np.any(valid > 0) else 1.0, 1e-9)
    u, v, mag = u / top, v / top, mag / top
    cw = wheel()
    n = len(cw)
    a = np.arctan2(-v, -u) / np.pi
    fk = (a + 1) / 2 * (n - 1)
    k0 = np.floor(fk).astype(int)
    k1 = (k0 + 1) % n
    f = (fk - k0)[..., None]
    col = (1 - f) * cw[k0] + f * cw[k1]
    col = 1 - mag[..., None] * (1 - col)
    col[valid == 0] = 0
    return (np.clip(col, 0, 1) * 255).astype(np.uint8)


def main(src, dst):
    with OpenEXR.File(src, separate_channels=True) as f:
        ch = f.channels()
        get = lambda n: np.asarray(ch[n].pixels, dtype=np.float64)
        rgb = np.stack([get(c) for c in ("R", "G", "B")], axis=-1)
        flow = flow_to_rgb(get("flowForward.X"), get("flowForward.Y"), get("flowValid.forward"))
    lin = np.clip(rgb, 0, 1)
    srgb = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055)
    beauty = (srgb * 255 + 0.5).astype(np.uint8)
    gap = np.full((beauty.shape[0], 8, 3), 255, np.uint8)
    Image.fromarray(np.concatenate([beauty, gap, flow], axis=1)).save(dst, optimize=True)
    print(f"wrote {dst}")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
