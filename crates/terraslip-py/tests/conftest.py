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


def require_shared(path):
    """Fails the calling test when `path` (under ../shared beside the
    checkout) is missing, unless TERRASLIP_ALLOW_NO_SHARED=1: then skips it."""
    if path.exists():
        return
    if os.environ.get("TERRASLIP_ALLOW_NO_SHARED") == "1":
        pytest.skip(f"{path}: missing (TERRASLIP_ALLOW_NO_SHARED=1)")
    pytest.fail(
        f"{path}: missing; this test needs the shared recordings beside the checkout "
        "(set TERRASLIP_ALLOW_NO_SHARED=1 to skip it)"
    )


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
