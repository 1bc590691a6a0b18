#!/usr/bin/env python3
"""Writes examples/animated/boxes.gltf: a 1-second glTF animation (24 frames at 24 fps) of two boxes
and a camera, for `obscura render --frames 1-24` and the ground-truth tests.

- node 0 "hero" (mesh "box"): translation LINEAR (-1.5, 0, 0) -> (1.5, 0, 0); rotation LINEAR about +Y,
  0 -> 90 degrees.
- node 1 "sidekick" (mesh "box"): translation STEP, (0, 1.2, -1) then (0, 0.6, -1) from t = 0.5;
  scale CUBICSPLINE 1 -> 1.5 with zero tangents.
- node 2 "camera": translation LINEAR (0, 0.5, 6) -> (0.5, 0.5, 6); a perspective camera, yfov 0.8.
- node 3 "ground" (mesh "ground"): a static 20 x 20 quad at y = -1.
"""
import base64
import json
import math
import struct
import sys
from pathlib import Path

out = Path(sys.argv[1] if len(sys.argv) > 1 else "examples/animated/boxes.gltf")
blob = bytearray()
views, accessors = [], []


def add(data, fmt, count, kind, comp=5126, target=None, minmax=None):
    while len(blob) % 4:
        blob.append(0)
    off = len(blob)
    for v in data:
        blob.extend(struct.pack(fmt, *v) if isinstance(v, tuple) else struct.pack(fmt, v))
    view = {"buffer": 0, "byteOffset": off, "byteLength": len(blob) - off}
    if target:
        view["target"] = target
    views.append(view)
    acc = {"bufferView": len(views) - 1, "componentType": comp, "count": count, "type": kind}
    if minmax:
        acc["min"], acc["max"] = minmax
    accessors.append(acc)
    return len(accessors) - 1


# A unit box: 8 corners, 12 triangles.
corners = [(x, y, z) for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]
faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
tris = [i for a, b, c, d in faces for i in (a, b, c, a, c, d)]
box_pos = add(corners, "<3f", 8, "VEC3", target=34962, minmax=([-0.5] * 3, [0.5] * 3))
box_idx = add(tris, "<H", len(tris), "SCALAR", comp=5123, target=34963)
ground = [(-10, -1, -10), (10, -1, -10), (10, -1, 10), (-10, -1, 10)]
ground_pos = add(ground, "<3f", 4, "VEC3", target=34962, minmax=([-10, -1, -10], [10, -1, 10]))
ground_idx = add([0, 2, 1, 0, 3, 2], "<H", 6, "SCALAR", comp=5123, target=34963)

t2 = add([0.0, 1.0], "<f", 2, "SCALAR", minmax=([0.0], [1.0]))
t_step = add([0.0, 0.5], "<f", 2, "SCALAR", minmax=([0.0], [0.5]))
hero_tr = add([(-1.5, 0, 0), (1.5, 0, 0)], "<3f", 2, "VEC3")
s45 = math.sin(math.pi / 4)
hero_rot = add([(0, 0, 0, 1), (0, s45, 0, s45)], "<4f", 2, "VEC4")
side_tr = add([(0, 1.2, -1), (0, 0.6, -1)], "<3f", 2, "VEC3")
side_sc = add([(0, 0, 0), (1, 1, 1), (0, 0, 0), (0, 0, 0), (1.5, 1.5, 1.5), (0, 0, 0)], "<3f", 6, "VEC3")
cam_tr = add([(0, 0.5, 6), (0.5, 0.5, 6)], "<3f", 2, "VEC3")

doc = {
    "asset": {"version": "2.0", "generator": "obscura scripts/animated_gltf.py"},
    "scene": 0,
    "scenes": [{"nodes": [0, 1, 2, 3]}],
    "nodes": [
        {"name": "hero", "mesh": 0, "translation": [-1.5, 0, 0]},
        {"name": "sidekick", "mesh": 0, "translation": [0, 1.2, -1]},
        {"name": "camera", "camera": 0, "translation": [0, 0.5, 6]},
        {"name": "ground", "mesh": 1},
    ],
    "meshes": [
        {"name": "box", "primitives": [{"attributes": {"POSITION": box_pos}, "indices": box_idx, "material": 0}]},
        {"name": "ground", "primitives": [{"attributes": {"POSITION": ground_pos}, "indices": ground_idx, "material": 1}]},
    ],
    "materials": [
        {"name": "orange", "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.4, 0.1, 1], "metallicFactor": 0, "roughnessFactor": 1}},
        {"name": "grey", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0, "roughnessFactor": 1}},
    ],
    "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}],
    "animations": [{
        "name": "move",
        "samplers": [
            {"input": t2, "output": hero_tr, "interpolation": "LINEAR"},
            {"input": t2, "output": hero_rot, "interpolation": "LINEAR"},
            {"input": t_step, "output": side_tr, "interpolation": "STEP"},
            {"input": t2, "output": side_sc, "interpolation": "CUBICSPLINE"},
            {"input": t2, "output": cam_tr, "interpolation": "LINEAR"},
        ],
        "channels": [
            {"sampler": 0, "target": {"node": 0, "path": "translation"}},
            {"sampler": 1, "target": {"node": 0, "path": "rotation"}},
            {"sampler": 2, "target": {"node": 1, "path": "translation"}},
            {"sampler": 3, "target": {"node": 1, "path": "scale"}},
            {"sampler": 4, "target": {"node": 2, "path": "translation"}},
        ],
    }],
    "bufferViews": views,
    "accessors": accessors,
    "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(blob)).decode()}],
}
out.parent.mkdir(parents=True, exist_ok=True)
out.write_text(json.dumps(doc, indent=1) + "\n")
print(f"wrote {out}")
