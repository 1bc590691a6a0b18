"""Reads a deep OpenEXR with the reference library (PyPI `OpenEXR`) and prints what it found.

Used by `obscura-render`'s deep-writer tests as a reader we did not write.

Output, on stdout:
    line 1: "<type> <dataWindow xmin ymin xmax ymax> <displayWindow xmin ymin xmax ymax> <channels...>"
    then one line per pixel and channel: "<x> <y> <channel> <sample values...>"
Values are printed with repr() of the float64 holding each float32 (exact round trip).
"""

import sys

import OpenEXR


def main(path):
    part = OpenEXR.File(path, separate_channels=True).parts[0]
    header = part.header
    (dx0, dy0), (dx1, dy1) = header["dataWindow"]
    (wx0, wy0), (wx1, wy1) = header["displayWindow"]
    kind = header["type"]
    kind = getattr(kind, "name", str(kind))
    names = sorted(part.channels.keys())
    windows = " ".join(str(int(v)) for v in (dx0, dy0, dx1, dy1, wx0, wy0, wx1, wy1))
    print(f"{kind} {windows} {' '.join(names)}")
    for name in names:
        pixels = part.channels[name].pixels
        height, width = pixels.shape
        for row in range(height):
            for col in range(width):
                samples = pixels[row, col]
                values = [] if samples is None else [repr(float(v)) for v in samples]
                print(" ".join([str(int(dx0) + col), str(int(dy0) + row), name] + values))


if __name__ == "__main__":
    main(sys.argv[1])
