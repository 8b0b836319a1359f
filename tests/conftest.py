"""Shared fixtures. Tests may read ../shared (papers' graph files, datasets); they skip cleanly
when it is absent so the suite still runs from a bare checkout."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
ANCHORS = SHARED / "anchors" / "andor-graphs"


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    if not SHARED.is_dir():
        pytest.skip("../shared is not present")
    return SHARED


@pytest.fixture(scope="session")
def anchors_dir() -> Path:
    if not ANCHORS.is_dir():
        pytest.skip("../shared/anchors/andor-graphs is not present")
    return ANCHORS
