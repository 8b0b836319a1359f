"""Fixtures of the sensing tests: the table assembly's truth, workspace and head camera."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def hmp_dir() -> Path:
    """The HMP dataset: ../shared/datasets/hmp (or $FLEXHRC_HMP, e.g. from a worktree)."""
    env = os.environ.get("FLEXHRC_HMP")
    return Path(env) if env else REPO.parent / "shared" / "datasets" / "hmp"


@pytest.fixture(scope="session")
def hmp() -> Path:
    path = hmp_dir()
    if not path.is_dir():
        pytest.skip(f"the HMP dataset is not at {path}")
    return path


def table(seed: int = 0, legs: int = 4):
    """(scenario, truth knowledge base) with legs laid out as bodies clear of each other."""
    from flexhrc.scenario.builtin.table import table_assembly
    from flexhrc.sensing.loop import lying_layout

    sc = table_assembly(
        segments="legs", legs=legs, seed=seed, leg_positions=lying_layout(legs, seed)
    )
    return sc, sc.world()
