#!/usr/bin/env bash
# The README's test command: every Rust test of the workspace, then the Python package's tests (the
# `obscura` wheel built with maturin, run with pytest), all with the independent checkers installed.
#
# The checkers we did not write (OpenEXR's Python reader, OpenCV with its contrib modules, pycolmap)
# go into the test's own virtual environment, which is first on PATH for both halves: the Rust tests
# call `python3` for them too. With OBSCURA_REQUIRE_* set a missing checker fails its test instead of
# skipping it, so a newcomer's run and CI's run the same tests and nothing is skipped. The farm tests
# at the end run a real single-node Slurm (Debian's slurm-wlm and munge, installed as root when
# missing) and Open Job Description's runner (openjd-cli, in a virtual environment of its own).
set -euo pipefail
cd "$(dirname "$0")"
root=$(pwd)
target=${CARGO_TARGET_DIR:-$root/target}

echo "== the test environment: a virtual environment with the build (maturin, pytest) and the checkers"
venv="$target/python-venv"
[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
py="$venv/bin/python"
export PATH="$venv/bin:$PATH"
if ! "$py" -c "import maturin, pytest, numpy, OpenEXR, cv2, pycolmap; cv2.omnidir; from pxr import Usd" 2>/dev/null; then
  # opencv-contrib-python-headless has cv2.omnidir; a plain OpenCV wheel installing cv2 too would
  # shadow it, so any is removed first.
  "$py" -m pip uninstall --quiet --yes opencv-python-headless opencv-python 2>/dev/null || true
  "$py" -m pip install --quiet --disable-pip-version-check \
    maturin pytest numpy OpenEXR opencv-contrib-python-headless pycolmap usd-core
fi
export OBSCURA_REQUIRE_INDEPENDENT_EXR=1
export OBSCURA_REQUIRE_OPENCV=1
export OBSCURA_REQUIRE_PYCOLMAP=1
# USD (issue 25): Pixar's usd-core (PyPI) is the reference reader the USD tests compare with.
export OBSCURA_REQUIRE_USD=1
# The shared corpora of public files (CI runs on this machine kind) must be there: the USD files
# (OBSCURA_USD_CORPUS) and the real 3DE/Nuke lens files (OBSCURA_LENS3DE_CORPUS).
export OBSCURA_REQUIRE_CORPORA=1
# The image sensor (issue 30): LibRaw, through rawpy, reads Obscura's DNG files.
if ! "$py" -c "import rawpy" 2>/dev/null; then
  "$py" -m pip install --quiet --disable-pip-version-check rawpy
fi
export OBSCURA_REQUIRE_RAWPY=1
# Dataset annotations (issue 28, wt-28b): NumPy (already installed above) reads the tracks and
# correspondences .npz files back.
export OBSCURA_REQUIRE_NUMPY=1

echo "== cargo test --workspace"
cargo test --workspace

echo "== the Python package: wheel (maturin), installed into the environment, pytest"
rm -rf "$target/wheels"
maturin build --release --quiet -m crates/obscura-python/Cargo.toml -o "$target/wheels"
"$py" -m pip install --quiet --disable-pip-version-check --force-reinstall --no-deps "$target"/wheels/obscura-*.whl
cargo build --release -q -p obscura
export OBSCURA_BIN="$target/release/obscura"
# From outside the source tree, so `import obscura` is the installed wheel.
(cd "$target" && "$py" -m pytest -q -p no:cacheprovider "$root/crates/obscura-python/tests")

# Farm engines (issue 27): a real single-node Slurm on loopback and Open Job Description's runner,
# running the shipped job files (scripts/farm) on the release obscura; outputs cmp-identical to a
# one-process render. Slurm's daemons are started and stopped by PID inside scripts/farm/ci-farm.sh.
echo "== farm: Slurm (slurm-wlm, munge) and openjd-cli, through the shipped job files"
if ! command -v slurmctld >/dev/null 2>&1 || ! command -v munged >/dev/null 2>&1; then
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null
fi
farm_venv="$target/openjd-venv"
[ -x "$farm_venv/bin/openjd" ] || { python3 -m venv "$farm_venv" && "$farm_venv/bin/pip" install --quiet --disable-pip-version-check openjd-cli==0.8.0; }
farm_start=$(date +%s)
scripts/farm/ci-farm.sh "$OBSCURA_BIN" "$farm_venv/bin/openjd"
echo "farm stage: $(( $(date +%s) - farm_start )) s"
