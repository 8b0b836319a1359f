"""The fuzz targets of :mod:`tests.fuzz.targets` on a short CI budget.

A fixed number of examples per target, drawn the same on every run (the deterministic profile
of ``tests/conftest.py``): a fresh clone cannot fail by luck. ``benchmarks/fuzz.py --minutes M``
runs the same targets long, with random seeds. A failure either finds prints its minimal input;
it becomes a case of its own below (fixed, or ``xfail(strict=True)`` naming the module to fix).
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings

from .targets import TARGETS, Hang, Target, Workspace

#: Examples per target in CI (the whole module well under a minute on two busy cores).
BUDGET = {"protocol": 300, "events": 300, "andor": 300, "scenario": 40, "store": 60, "replay": 400}


@pytest.fixture(scope="module")
def ws(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Workspace]:
    yield Workspace(tmp_path_factory.mktemp("fuzz"))


def _fuzz(target: Target, ws: Workspace) -> None:
    @settings(
        max_examples=BUDGET[target.name],
        deadline=None,  # the watchdog judges hangs; no wall-clock limit per example
        suppress_health_check=list(HealthCheck),
    )
    @given(target.inputs())
    def run(value: Any) -> None:
        try:
            target.run(ws, value, known=True)  # (a known finding: its xfail test pins it)
        except Hang:  # not shrunk (each try would take the watchdog's time): shown as it is
            print(f"{target.name}: a hang on {value!r:.4000}", file=sys.stderr)
            raise

    run()


@pytest.mark.parametrize("name", sorted(BUDGET))
def test_fuzz_target(name: str, ws: Workspace) -> None:
    _fuzz(TARGETS[name], ws)


def test_every_target_has_a_ci_budget() -> None:
    assert set(BUDGET) == set(TARGETS)


def test_the_andor_corpus_holds_the_shipped_files() -> None:
    from .targets import andor_seeds

    names = {rel for _, rel in andor_seeds()}
    assert {"connect_leg.txt", "table_2legs.txt"} <= names


def test_shared_anchors_are_in_the_corpus(anchors_dir: Path) -> None:
    from .targets import andor_seeds

    assert any(str(folder).startswith(str(anchors_dir)) for folder, _ in andor_seeds())
