"""Writes docs/python-api.md, the Python API reference, from the installed module's docstrings and
signatures. Usage: python3 crates/obscura-python/scripts/api_docs.py [OUT] (default docs/python-api.md).

A test (tests/test_docs.py) regenerates it and fails when the committed file is out of date.
"""

import inspect
import sys
from pathlib import Path

import obscura

ROOT = Path(__file__).resolve().parents[3]


def signature(obj, name):
    text = getattr(obj, "__text_signature__", None)
    if text:
        return name + text.replace("($self, ", "(").replace("($self)", "()").replace("($cls, ", "(").replace("$", "")
    try:
        return name + str(inspect.signature(obj))
    except (TypeError, ValueError):
        return name + "(...)"


def doc(obj):
    return inspect.cleandoc(obj.__doc__ or "").strip()


def render():
    out = [
        "# obscura (Python) — API reference",
        "",
        "Generated from the docstrings by `python3 crates/obscura-python/scripts/api_docs.py`; "
        "`tests/test_docs.py` fails when this file is out of date. Type stubs: "
        "`crates/obscura-python/python/obscura/_obscura.pyi`.",
        "",
        doc(obscura),
        "",
        "## `Camera`",
        "",
        "```python",
        "Camera(projection='PxrPerspective', **kwargs)",
        "```",
        "",
        doc(obscura.Camera),
        "",
    ]
    members = sorted(vars(obscura.Camera).items())
    methods = [(n, m) for n, m in members if not n.startswith("_") and callable(m)]
    props = [(n, m) for n, m in members if not n.startswith("_") and not callable(m)]
    for name, m in methods:
        out += [f"### `Camera.{signature(m, name)}`", "", doc(m), ""]
    out += ["### Properties", "", "| property | meaning |", "|---|---|"]
    for name, p in props:
        out.append(f"| `{name}` | {' '.join(doc(p).split())} |")
    out += ["", "## Functions", ""]
    for name in sorted(obscura.__all__):
        f = getattr(obscura, name)
        if name.startswith("_") or isinstance(f, type) or not callable(f):
            continue
        out += [f"### `obscura.{signature(f, name)}`", "", doc(f), ""]
    return "\n".join(out).rstrip() + "\n"


if __name__ == "__main__":
    path = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "python-api.md"
    path.write_text(render())
    print(f"wrote {path}")
