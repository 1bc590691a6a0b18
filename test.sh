#!/usr/bin/env bash
# The README's test command: every Rust test of the workspace, then the Python package's tests
# (the `obscura` wheel built with maturin, installed into a virtual environment, run with pytest).
set -euo pipefail
cd "$(dirname "$0")"
root=$(pwd)
target=${CARGO_TARGET_DIR:-$root/target}

cargo test --workspace

echo "== the Python package: wheel (maturin), virtual environment, pytest"
venv="$target/python-venv"
# The venv sees the system's packages, so checkers installed there (OpenCV, pycolmap, OpenEXR) are used.
[ -x "$venv/bin/python" ] || python3 -m venv --system-site-packages "$venv"
py="$venv/bin/python"
export PATH="$venv/bin:$PATH"
if ! command -v maturin >/dev/null || ! "$py" -c "import pytest, numpy" 2>/dev/null; then
  "$py" -m pip install --quiet --disable-pip-version-check maturin pytest numpy
fi
rm -rf "$target/wheels"
maturin build --release --quiet -m crates/obscura-python/Cargo.toml -o "$target/wheels"
"$py" -m pip install --quiet --disable-pip-version-check --force-reinstall --no-deps "$target"/wheels/obscura-*.whl
cargo build --release -q -p obscura
export OBSCURA_BIN="$target/release/obscura"
# From outside the source tree, so `import obscura` is the installed wheel.
cd "$target" && "$py" -m pytest -q -p no:cacheprovider "$root/crates/obscura-python/tests"
