"""Shared fixtures of the Python tests: the repository root, the checkers we did not write (OpenCV,
pycolmap; with OBSCURA_REQUIRE_OPENCV / OBSCURA_REQUIRE_PYCOLMAP set, as .ci/run does, a missing one
fails instead of skipping), the `obscura` binary and a C compiler."""

import importlib
import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
FIXTURES = ROOT / "crates" / "obscura-calibration" / "tests" / "fixtures"


def checker(module, env):
    """Imports `module`, skipping the test when it is missing unless `env` is set."""
    try:
        return importlib.import_module(module)
    except ImportError as e:
        if os.environ.get(env):
            pytest.fail(f"{env} is set but {module} cannot be imported: {e}")
        pytest.skip(f"{module} is not installed")


@pytest.fixture(scope="session")
def cv2():
    cv = checker("cv2", "OBSCURA_REQUIRE_OPENCV")
    if not hasattr(cv, "omnidir"):
        if os.environ.get("OBSCURA_REQUIRE_OPENCV"):
            pytest.fail("cv2.omnidir is missing: install opencv-contrib-python-headless")
        pytest.skip("cv2.omnidir needs opencv-contrib-python-headless")
    return cv


@pytest.fixture(scope="session")
def pycolmap():
    return checker("pycolmap", "OBSCURA_REQUIRE_PYCOLMAP")


@pytest.fixture(scope="session")
def obscura_bin():
    """The release `obscura` binary (OBSCURA_BIN, else built with cargo)."""
    given = os.environ.get("OBSCURA_BIN")
    if given:
        return Path(given)
    subprocess.run(
        ["cargo", "build", "--release", "-q", "-p", "obscura"], cwd=ROOT, check=True
    )
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    return target / "release" / "obscura"


@pytest.fixture(scope="session")
def c_compiler():
    cc = os.environ.get("CC", "cc")
    if shutil.which(cc) is None:
        pytest.fail(f"no C compiler ({cc}): the plugin test compiles a C plugin")
    return cc
