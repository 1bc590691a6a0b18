"""Draws a dataset frame's boxes and point tracks over its PNG: the README's picture.

    python3 scripts/dataset/draw_annotations.py DIR CAMERA FRAME OUT.png [--crop X0 Y0 X1 Y1] [--scale S]

Tight visible boxes (`bbox`) in solid colour, the box of the whole object (`bbox_full`) dashed; track
points visible (status 0) as filled dots, occluded (1) as rings; out of frame or outside the
projection's domain are not drawn. Needs numpy and Pillow.
"""

import argparse
import json
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

COLOURS = [(255, 80, 80), (80, 200, 255), (255, 210, 60), (120, 255, 120), (255, 120, 255), (255, 160, 60)]


def dashed(draw, box, colour, scale, step=4):
    x0, y0, x1, y1 = box
    for a, b, horizontal in [((x0, y0), (x1, y0), True), ((x0, y1), (x1, y1), True), ((x0, y0), (x0, y1), False), ((x1, y0), (x1, y1), False)]:
        length = (b[0] - a[0]) if horizontal else (b[1] - a[1])
        t = 0.0
        while t < length:
            e = min(t + step, length)
            if horizontal:
                draw.line([(a[0] + t, a[1]), (a[0] + e, a[1])], fill=colour, width=max(1, scale // 2))
            else:
                draw.line([(a[0], a[1] + t), (a[0], a[1] + e)], fill=colour, width=max(1, scale // 2))
            t += 2 * step


def main():
    p = argparse.ArgumentParser()
    p.add_argument("root", type=Path)
    p.add_argument("camera")
    p.add_argument("frame", type=int)
    p.add_argument("out", type=Path)
    p.add_argument("--crop", type=float, nargs=4, default=None)
    p.add_argument("--scale", type=int, default=1)
    p.add_argument("--max-area", type=float, default=0.25, help="skip boxes covering more of the image (floor, walls)")
    a = p.parse_args()
    name = f"{a.frame:04d}"
    image = Image.open(a.root / "images" / a.camera / f"{name}.png").convert("RGB")
    w, h = image.size
    x0, y0, x1, y1 = a.crop or (0, 0, w, h)
    s = a.scale
    image = image.crop((int(x0), int(y0), int(x1), int(y1))).resize((int((x1 - x0) * s), int((y1 - y0) * s)), Image.NEAREST)
    draw = ImageDraw.Draw(image)
    to = lambda x, y: ((x - x0) * s, (y - y0) * s)
    coco = json.loads((a.root / "annotations" / a.camera / f"{name}.json").read_text())
    for i, ann in enumerate(coco["annotations"]):
        colour = COLOURS[i % len(COLOURS)]
        full = ann.get("bbox_full")
        if full and full[2] * full[3] > a.max_area * w * h:
            continue
        if full:
            bx, by, bw, bh = full
            dashed(draw, (*to(bx, by), *to(bx + bw, by + bh)), colour, s)
        if ann.get("bbox"):
            bx, by, bw, bh = ann["bbox"]
            draw.rectangle([to(bx, by), to(bx + bw, by + bh)], outline=colour, width=max(1, s))
    tracks = np.load(a.root / "tracks" / f"{a.camera}.npz")
    frames = list(tracks["frames"]) if "frames" in tracks else [a.frame]
    t = frames.index(a.frame)
    for (x, y), status in zip(tracks["points"][:, t], tracks["status"][:, t]):
        if status > 1:
            continue
        cx, cy = to(x, y)
        r = 1.5 * s
        if status == 0:
            draw.ellipse([cx - r, cy - r, cx + r, cy + r], fill=(255, 255, 255))
        else:
            draw.ellipse([cx - r, cy - r, cx + r, cy + r], outline=(255, 255, 255))
    image.save(a.out, optimize=True)


if __name__ == "__main__":
    main()
