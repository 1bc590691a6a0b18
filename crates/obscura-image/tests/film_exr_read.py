"""Reads a flat OpenEXR with the reference library (PyPI `OpenEXR`) and prints what it found.

Used by `obscura-render`'s output tests as a reader we did not write.

Output, on stdout:
    "dataWindow xmin ymin xmax ymax displayWindow xmin ymin xmax ymax"
    "pixelAspectRatio <value> compression <name>"
    "projection <value of the 'projection' string attribute, or -> "
    then one line per channel, sorted by name: "<name> <dtype> <values, row by row...>"
Values are printed with repr() of the float64 holding each value (exact round trip).
"""

import sys

import OpenEXR


def main(path):
    part = OpenEXR.File(path, separate_channels=True).parts[0]
    header = part.header
    (dx0, dy0), (dx1, dy1) = header["dataWindow"]
    (wx0, wy0), (wx1, wy1) = header["displayWindow"]
    windows = " ".join(str(int(v)) for v in (dx0, dy0, dx1, dy1))
    display = " ".join(str(int(v)) for v in (wx0, wy0, wx1, wy1))
    print(f"dataWindow {windows} displayWindow {display}")
    compression = header["compression"]
    compression = getattr(compression, "name", str(compression))
    print(f"pixelAspectRatio {header['pixelAspectRatio']!r} compression {compression}")
    print(f"projection {header.get('projection', '-')}")
    for name in sorted(part.channels.keys()):
        pixels = part.channels[name].pixels
        values = [repr(float(v)) for v in pixels.reshape(-1)]
        print(" ".join([name, str(pixels.dtype)] + values))


if __name__ == "__main__":
    main(sys.argv[1])
