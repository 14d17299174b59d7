"""Tests that need the shared recordings (../shared beside the checkout)
skip, saying why, where they are missing; TERRASLIP_REQUIRE_SHARED=1 makes
that a failure."""

import pytest

from conftest import REQUIRE_SHARED, REPO, require_shared


def test_a_missing_recording_is_skipped_unless_required(monkeypatch, tmp_path):
    missing = tmp_path / "no" / "such" / "recording"
    monkeypatch.delenv(REQUIRE_SHARED, raising=False)
    with pytest.raises(pytest.skip.Exception, match="skipped: .*recording is missing"):
        require_shared(missing)
    monkeypatch.setenv(REQUIRE_SHARED, "1")
    with pytest.raises(pytest.fail.Exception, match="recording is missing"):
        require_shared(missing)
    require_shared(REPO / "data" / "husky_test1")
