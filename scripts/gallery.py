#!/usr/bin/env python3
"""Regenerates docs/gallery.png: the built-in scene rendered through every registered projection.

Setup (once):

    python3 -m pip install pillow          # labels and the contact sheet (no ImageMagick needed)

Run from anywhere (it builds the release binary first unless --no-build):

    python3 scripts/gallery.py             # docs/gallery.png + docs/gallery.txt

The list of projections comes from the binary (`obscura plugins --names`), so a projection added to the
library appears without editing this file. TILES below gives the parameters and image shape that show
each projection well (and extra tiles for interesting variants); a projection missing from TILES gets a
default tile and a warning. Parameters a projection does not declare are dropped with a warning, and a
tile whose parameters are refused is rendered with the defaults (a warning again; --strict makes both
errors), so the sheet always holds every projection.

docs/gallery.txt lists the tiles, one per line: projection name, size, parameters. The Rust test
crates/obscura-cli/tests/gallery.rs fails when a registered projection has no line there.

Each tile is ~320 px wide at 16 samples per pixel; the whole sheet takes a few minutes on two cores.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


@dataclass
class Tile:
    """One picture: a label suffix, parameters ("name=value"; "name=~word" picks the first declared
    choice containing word), and the image's aspect (width / height)."""

    note: str = ""
    params: list[str] = field(default_factory=list)
    aspect: float = 16 / 9


# Per projection, the tiles that show it well. Names and values follow the issue and RenderMan.
TILES: dict[str, list[Tile]] = {
    "PxrPerspective": [Tile("fov 60", ["fov=60"])],
    "PxrOrthographic": [Tile("", [])],
    "PxrCamera": [
        Tile(
            "barrel distortion, natural vignetting",
            ["fov=70", "radial1=-0.12", "natural=1"],
        ),
        Tile(
            "tilt-shift: focal plane tilted 8°, f/1.4",
            ["fov=50", "fStop=1.4", "focalLength=0.1", "focalDistance=6", "tilt=8"],
        ),
        Tile(
            "chromatic aberration, cat's-eye vignetting",
            ["fov=60", "transverse=0.97,1,1.03", "optical=1.5", "fStop=2", "focalLength=0.08", "focalDistance=5"],
        ),
    ],
    "PxrSphereCamera": [Tile("360 x 180 equirectangular", ["hsweep=360", "vsweep=180"], 2.0)],
    "PxrCylinderCamera": [Tile("360 x 90", ["hsweep=360", "vsweep=90"], 2.0)],
    "PxrPanini": [Tile("fov 150, compression 1", ["fov=150", "compression=1"], 2.0)],
    "OmnidirectionalStereo": [Tile("left eye, 360 x 180", ["eye=left"], 2.0)],
    # The sweep rewrites only each ray's time, so a still scene looks as through PxrPerspective.
    "PxrRollingShutter": [Tile("sweep down over half the shutter (still scene)", ["sweep=down", "duration=0.5"])],
    "Fisheye": [
        Tile("equidistant 180", ["mapping=equidistant", "fov=180"], 1.0),
        Tile("stereographic 220", ["mapping=stereographic", "fov=220"], 1.0),
        Tile("equisolid 10.5 mm on 36 mm", ["mapping=equisolid"], 1.5),
        Tile("orthographic 180", ["mapping=orthographic", "fov=180"], 1.0),
        Tile(
            "polynomial (Cycles' k0..k4), 200",
            ["mapping=polynomial", "polynomial=0,-0.1,0,-0.0001,0", "fov=200"],
            1.0,
        ),
    ],
    "MirrorBall": [
        Tile("Cycles' orientation: centre +Z, rim -Z", ["orientation=camera"], 1.0),
        Tile("light probe: centre -Z, rim +Z", ["orientation=lightprobe"], 1.0),
    ],
    "EquiangularCubemapFace": [Tile("front face", [], 1.0)],
    "LensSystem": [Tile("double Gauss 50 mm f/2 at 4, d line: vignetting, distortion", ["focusDistance=4", "dispersion=0"])],
    "Octahedral": [Tile("equal-area sphere", [], 1.0)],
    "CalibratedCamera": [
        Tile(
            "OPENCV_FISHEYE (Kannala-Brandt), 190°",
            [
                "model=OPENCV_FISHEYE",
                "params=150,150,256,256,0.02,-0.004,0,0",
                "resolution=512,512",
            ],
            1.0,
        ),
    ],
}

DECL = re.compile(r'^\s+"(?P<type>[a-z]+(?:\[\d*\])?) (?P<name>\w+)"\s+(?P<default>\[[^\]]*\])\s+(?P<rest>.*)$')


def run(cmd: list[str], **kw) -> subprocess.CompletedProcess:
    return subprocess.run(cmd, capture_output=True, text=True, **kw)


def declared(obscura: str, name: str) -> dict[str, list[str]]:
    """The projection's parameters: name -> its choices (empty when free)."""
    out = run([obscura, "plugins", name])
    if out.returncode != 0:
        sys.exit(f"error: obscura plugins {name}: {out.stderr.strip()}")
    table = {}
    for line in out.stdout.splitlines():
        m = DECL.match(line)
        if m:
            first = m["rest"].split(" ")[0] if m["rest"] else ""
            table[m["name"]] = first.split("|") if "|" in first else []
    return table


def resolve(name: str, tile: Tile, table: dict[str, list[str]], strict: bool) -> list[str]:
    """The tile's parameters that the projection declares, with ~word choices resolved."""
    params = []
    for p in tile.params:
        key, _, value = p.partition("=")
        if key not in table:
            warn(f"{name}: no parameter {key!r}; tile {tile.note!r} drops {p!r}", strict)
            continue
        if value.startswith("~"):
            match = [c for c in table[key] if value[1:].lower() in c.lower()]
            if not match:
                warn(f"{name}: no choice of {key} contains {value[1:]!r}; dropping {p!r}", strict)
                continue
            value = match[0]
        params.append(f"{key}={value}")
    return params


def warn(message: str, strict: bool) -> None:
    if strict:
        sys.exit(f"error: {message}")
    print(f"warning: {message}", file=sys.stderr)


def render(obscura: str, name: str, params: list[str], size: tuple[int, int], spp: int, out: Path):
    cmd = [obscura, "render", "-p", name, "--format", f"{size[0]}x{size[1]}", "--spp", str(spp), "--quiet"]
    for p in params:
        cmd += ["--param", p]
    return run(cmd + ["-o", str(out)])


def font(size: int):
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1 has only the fixed bitmap font
        return ImageFont.load_default()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--obscura", help="the obscura binary (default: target/release/obscura, built first)")
    ap.add_argument("--no-build", action="store_true", help="do not run cargo build --release")
    ap.add_argument("--width", type=int, default=320, help="tile width in pixels (default 320)")
    ap.add_argument("--spp", type=int, default=16, help="samples per pixel (default 16)")
    ap.add_argument("--columns", type=int, default=4, help="tiles per row (default 4)")
    ap.add_argument("--out", default=str(ROOT / "docs" / "gallery.png"))
    ap.add_argument("--manifest", default=str(ROOT / "docs" / "gallery.txt"))
    ap.add_argument("--strict", action="store_true", help="fail instead of falling back to defaults")
    a = ap.parse_args()

    try:
        from PIL import Image, ImageDraw
    except ImportError:
        sys.exit("error: Pillow is missing: python3 -m pip install pillow")

    started = time.monotonic()
    obscura = a.obscura or str(ROOT / "target" / "release" / "obscura")
    if not a.obscura and not a.no_build:
        print("building the release binary ...", file=sys.stderr)
        b = subprocess.run(["cargo", "build", "--release", "-q", "-p", "obscura"], cwd=ROOT)
        if b.returncode != 0:
            sys.exit("error: cargo build --release -p obscura failed")
    names = run([obscura, "plugins", "--names"])
    if names.returncode != 0:
        sys.exit(f"error: {obscura} plugins --names: {names.stderr.strip()}")
    registered = [n for n in names.stdout.split() if n]
    for n in TILES:
        if n not in registered:
            print(f"note: {n} is in the gallery table but not registered; no tile", file=sys.stderr)

    rendered = []  # (name, note, params, size, image)
    with tempfile.TemporaryDirectory(prefix="obscura-gallery-") as tmp:
        for name in registered:
            tiles = TILES.get(name)
            if tiles is None:
                warn(f"{name} has no entry in scripts/gallery.py's TILES: default tile", a.strict)
                tiles = [Tile("defaults", [])]
            table = declared(obscura, name)
            for k, tile in enumerate(tiles):
                params = resolve(name, tile, table, a.strict)
                size = (a.width, max(1, round(a.width / tile.aspect)))
                png = Path(tmp) / f"{name}-{k}.png"
                t0 = time.monotonic()
                r = render(obscura, name, params, size, a.spp, png)
                note = tile.note
                if r.returncode != 0:
                    warn(f"{name} {params}: {r.stderr.strip()}; rendering its defaults instead", a.strict)
                    params, note = [], "defaults"
                    r = render(obscura, name, params, size, a.spp, png)
                    if r.returncode != 0:
                        sys.exit(f"error: {name} with default parameters: {r.stderr.strip()}")
                print(f"{name:24s} {size[0]}x{size[1]} {' '.join(params):48s} {time.monotonic() - t0:5.1f} s")
                rendered.append((name, note, params, size, Image.open(png).convert("RGB")))

    # The contact sheet: rows of up to --columns tiles, each labelled underneath.
    pad, label_h = 12, 40
    title_font, name_font, note_font = font(20), font(15), font(12)
    rows = [rendered[i : i + a.columns] for i in range(0, len(rendered), a.columns)]
    title = f"Obscura projections: the built-in scene through each ({a.spp} spp)"
    measure = ImageDraw.Draw(Image.new("RGB", (1, 1)))
    sheet_w = max(pad + a.columns * (a.width + pad), 2 * pad + int(measure.textlength(title, font=title_font)))
    title_h = 48
    row_h = [max(t[3][1] for t in row) + label_h + pad for row in rows]
    sheet = Image.new("RGB", (sheet_w, title_h + sum(row_h) + pad), (28, 28, 30))
    draw = ImageDraw.Draw(sheet)
    draw.text((pad, 14), title, font=title_font, fill=(235, 235, 235))

    def fit(text: str, f) -> str:
        """The text, cut with an ellipsis to the tile's width."""
        if draw.textlength(text, font=f) <= a.width:
            return text
        while text and draw.textlength(text + "…", font=f) > a.width:
            text = text[:-1]
        return text + "…"

    y = title_h
    for row, h in zip(rows, row_h):
        x = pad
        for name, note, params, size, img in row:
            sheet.paste(img, (x, y))
            ty = y + size[1] + 4
            draw.text((x, ty), fit(name, name_font), font=name_font, fill=(240, 240, 240))
            caption = note or " ".join(params) or "default parameters"
            draw.text((x, ty + 18), fit(caption, note_font), font=note_font, fill=(170, 170, 175))
            x += a.width + pad
        y += h
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    sheet.save(out, optimize=True)

    lines = [
        "# docs/gallery.png tiles, one per line: projection, size, parameters.",
        "# Written by scripts/gallery.py; crates/obscura-cli/tests/gallery.rs checks every registered",
        "# projection has a line here.",
    ]
    for name, note, params, size, _ in rendered:
        lines.append(f"{name}\t{size[0]}x{size[1]}\t{' '.join(params) or '-'}")
    Path(a.manifest).write_text("\n".join(lines) + "\n")
    print(f"wrote {out} ({len(rendered)} tiles of {len(registered)} projections) and {a.manifest} "
          f"in {time.monotonic() - started:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
