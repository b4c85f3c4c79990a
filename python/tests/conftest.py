"""Shared fixtures: where the repository, the real data and the `kincal` binary are."""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
# The real data sets live beside the repository (../shared), never inside it.
REALDATA = Path(os.environ.get("KINCAL_REALDATA", REPO.parent / "shared" / "realdata"))
UR10E_URDF = REALDATA / "figaroh-ur10e" / "robot_ur10e.urdf"


def ci() -> bool:
    return os.environ.get("CI") == "true"


def need(condition: bool, why: str) -> None:
    """Skip a test whose input is missing, except in CI where that is a failure."""
    if not condition:
        if ci():
            pytest.fail(why + " (CI=true: a missing input is a failure)")
        pytest.skip(why)


@pytest.fixture(scope="session")
def kincal_bin() -> Path:
    """The command-line binary: $KINCAL_BIN, else target/{release,debug}/kincal."""
    given = os.environ.get("KINCAL_BIN")
    candidates = [Path(given)] if given else [
        REPO / "target" / "release" / "kincal",
        REPO / "target" / "debug" / "kincal",
    ]
    for c in candidates:
        if c.is_file():
            return c
    found = shutil.which("kincal")
    need(found is not None, "no kincal binary: set KINCAL_BIN or build it (cargo build -p kincal-cli)")
    return Path(found)


def run_cli(kincal_bin: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(kincal_bin), *args], capture_output=True, text=True)
