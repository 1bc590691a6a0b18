"""Reads Obscura's DNG with LibRaw (rawpy, PyPI) and its EXR with OpenEXR, both libraries we did not
write, and checks them against each other.

Usage: rawpy_dng.py DNG EXR PATTERN BLACK WHITE MODE
  MODE "bilinear": the EXR's beauty is Obscura's ISP with bilinear demosaic and no tone curve; LibRaw's
  LINEAR demosaic to linear sRGB must give the same image up to one exposure factor of its own, the
  same for the three channels within 0.1 %, every interior pixel within 1e-3 of full scale and the
  mean within 1e-4 (LibRaw rounds to 16-bit integers three times).
  MODE "malvar": the EXR's beauty used Malvar-He-Cutler; against LibRaw's AHD (another edge-aware
  method) the mean absolute difference must stay below 3 % of full scale.
Prints one line of figures.
"""
import sys

import numpy as np
import OpenEXR
import rawpy

dng, exr, pattern, black, white, mode = sys.argv[1:7]
channels = OpenEXR.File(exr).channels()
beauty = channels["RGBA"].pixels[..., :3].astype(np.float64)
mosaic = channels["raw"].pixels

r = rawpy.imread(dng)
# The pattern LibRaw reads: its colour indices (0 R, 1 G, 2 B, 3 the second G) through color_desc.
desc = r.color_desc.decode()
letters = "".join(desc[i] for i in r.raw_pattern.flatten())
assert letters == pattern, f"pattern {letters} != {pattern}"
assert list(r.black_level_per_channel) == [int(black)] * 4, r.black_level_per_channel
assert r.white_level == int(white), r.white_level
raw = r.raw_image_visible
assert raw.shape == mosaic.shape, (raw.shape, mosaic.shape)
assert np.array_equal(raw.astype(np.float32), mosaic), "raw values differ from the EXR's raw channel"

algorithm = rawpy.DemosaicAlgorithm.LINEAR if mode == "bilinear" else rawpy.DemosaicAlgorithm.AHD
out = r.postprocess(
    demosaic_algorithm=algorithm,
    use_camera_wb=True,
    output_color=rawpy.ColorSpace.sRGB,
    gamma=(1, 1),
    no_auto_bright=True,
    output_bps=16,
    user_flip=0,
    highlight_mode=rawpy.HighlightMode.Ignore,
).astype(np.float64) / 65535.0
inner = (slice(4, -4), slice(4, -4))
a, b = out[inner], beauty[inner]
# Pixels clipped by either side's 16-bit range or black carry no comparison.
use = (b.max(-1) < 0.9) & (b.min(-1) > 0.01) & (a.max(-1) < 0.99)
assert use.sum() > 0.5 * use.size, f"only {use.sum()} of {use.size} pixels comparable"
scale = np.median(a[use] / b[use], axis=0)
spread = scale.max() / scale.min() - 1
diff = np.abs(a[use] / scale.mean() - b[use])
if mode == "bilinear":
    assert spread < 1e-3, f"channel factors {scale} differ by {spread:.2e}"
    # LibRaw works in 16-bit integers: one of its steps is 1/65535 of its own scale, about 6.5e-5 of
    # ours at its factor of ~0.23; it rounds after white balance, after interpolation and after the
    # colour matrix.
    assert diff.max() < 1e-3 and diff.mean() < 1e-4, f"difference max {diff.max():.2e} mean {diff.mean():.2e}"
else:
    assert diff.mean() < 0.03, f"mean difference {diff.mean():.4f}"
print(f"{mode}: pattern {letters}, black {black}, white {white}, raw identical; LibRaw factor {scale.mean():.5f} "
      f"(channels within {spread:.1e}), difference max {diff.max():.2e} mean {diff.mean():.2e}")
