"""Helpers of the panel tests: a manual clock and a driver for :class:`LocalCooperation`."""

from __future__ import annotations

from typing import Any

from flexhrc.web.local import LocalCooperation, table_assembly


class ManualClock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def manual_table(legs: int = 4, **kw: Any) -> tuple[LocalCooperation, ManualClock]:
    clock = ManualClock()
    coop = table_assembly(legs, clock=clock, **kw)
    coop.start(background=False)
    return coop, clock


def advance(coop: LocalCooperation, clock: ManualClock, steps: int = 1) -> None:
    """Let the next ``steps`` robot completions happen."""
    for _ in range(steps):
        due = coop.next_due()
        if due is None:
            return
        clock.t = max(clock.t, due / coop.speed)
        coop.run_due()


def run_robots(coop: LocalCooperation, clock: ManualClock, limit: int = 500) -> None:
    """Let the robots work until they wait for the operator (or the end)."""
    for _ in range(limit):
        if coop.next_due() is None:
            return
        advance(coop, clock)
    raise AssertionError("robots never stopped working")


def human_next(coop: LocalCooperation) -> list[str]:
    return [s["next"] for s in coop.snapshot()["suggestions"] if s["owner"] == "human"]


def finish(coop: LocalCooperation, clock: ManualClock, limit: int = 100) -> str:
    """Robots work; the operator presses 'done' on whatever is suggested to them; to the end."""
    for _ in range(limit):
        run_robots(coop, clock)
        if coop.tm.done:
            return coop.tm.outcome
        asked = human_next(coop)
        if not asked:
            return coop.tm.outcome
        coop.submit({"action": asked[0]})
    raise AssertionError("the cooperation did not end")
