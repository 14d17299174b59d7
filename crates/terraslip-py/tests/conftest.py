"""Shared fixtures: the repository's sample drives and the command line
the package must agree with (TERRASLIP_CLI, else target/release/terraslip)."""

import csv
import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]
DRIVE = REPO / "data" / "warthog_gravel"
BOREAL = REPO / "data" / "ice_borealtc_04"
# The Husky ROS 2 recording the repository ships (MCAP).
HUSKY = REPO / "data" / "husky_test1"


SHARED = REPO.parent / "shared" / "data"
REQUIRE_SHARED = "TERRASLIP_REQUIRE_SHARED"


def require_shared(path):
    """Skips the calling test, saying so, when `path` (under ../shared
    beside the checkout: the full recordings, which the repository does not
    ship) is missing; fails it instead when TERRASLIP_REQUIRE_SHARED=1 (as
    CI sets it)."""
    if path.exists():
        return
    if os.environ.get(REQUIRE_SHARED) == "1":
        pytest.fail(f"{path} is missing: this test needs the shared recordings beside the checkout ({REQUIRE_SHARED}=1)")
    pytest.skip(f"skipped: {path} is missing (the shared recordings beside the checkout; {REQUIRE_SHARED}=1 makes this a failure)")


@pytest.fixture
def shared_present():
    """For tests that read ../shared/data: see `require_shared`."""
    require_shared(SHARED)


@pytest.fixture(scope="session")
def cli():
    """Runs the terraslip command; returns the CompletedProcess."""
    exe = Path(os.environ.get("TERRASLIP_CLI", REPO / "target" / "release" / "terraslip"))
    if not exe.is_file():
        pytest.fail(f"{exe}: no terraslip command to compare with (cargo build --release -p terraslip, or set TERRASLIP_CLI)")

    def run(*args, check=True):
        return subprocess.run(
            [str(exe), *map(str, args)], capture_output=True, text=True, check=check, cwd=REPO
        )

    return run


def cli_error(proc):
    """The message of the command's `error: ...` line."""
    assert proc.returncode != 0, proc.stderr
    lines = [l for l in proc.stderr.splitlines() if l.startswith("error: ")]
    assert lines, proc.stderr
    return lines[-1][len("error: "):]


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))
