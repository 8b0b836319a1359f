"""Shared fixtures. Tests may read ../shared (papers' graph files, datasets); they skip cleanly
when it is absent so the suite still runs from a bare checkout."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import settings

# Property tests draw the same examples on every run: a test that fails once on a fresh clone
# is a defect, not bad luck. `FLEXHRC_FUZZ=1 pytest ...` explores new examples (more of them);
# a failure it finds becomes a fixed case of its own.
settings.register_profile("deterministic", derandomize=True, database=None)
settings.register_profile("fuzz", max_examples=1000, deadline=None)
settings.load_profile("fuzz" if os.environ.get("FLEXHRC_FUZZ") else "deterministic")

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


SRC = REPO / "src"


def subprocess_env() -> dict[str, str]:
    """Environment for running ``python -m flexhrc`` from the source tree in a subprocess."""
    import os

    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(SRC), env.get("PYTHONPATH", "")) if p)
    return env
