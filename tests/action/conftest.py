"""Fixtures of the action-level tests: one robot and one simulator for the whole session (loading
the URDF and building the pinocchio models is the only slow part)."""

from __future__ import annotations

import pytest

pytest.importorskip("pinocchio", reason="the action level needs the 'sim' extra")

from flexhrc.action.simulator import KinematicSimulator


@pytest.fixture(scope="session")
def sim() -> KinematicSimulator:
    return KinematicSimulator()


@pytest.fixture(scope="session")
def robot(sim: KinematicSimulator):
    return sim.robot
