"""Helpers of the panel tests: scenarios, and waiting on a running panel for what it shows.

Waits are on the panel's own change notifications (``subscribe``), never on a fixed sleep.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

from flexhrc.web import PanelInputError

# the legs fix of the table (the older file format every command reads)
TABLE = "scenario: table_assembly\n"
TABLE_HUMAN_BOLT_1 = "scenario: table_assembly\nunreachable_bolts: [1]\n"
TABLE_HUMAN_BOLT_2 = "scenario: table_assembly\nunreachable_bolts: [2]\n"


def until(
    panel: Any, check: Callable[[dict[str, Any]], bool], timeout: float = 30.0
) -> dict[str, Any]:
    """The first snapshot of ``panel`` for which ``check`` holds (woken by each change)."""
    changed = threading.Event()
    cancel = panel.subscribe(changed.set)
    deadline = time.monotonic() + timeout
    try:
        while True:
            changed.clear()
            snap: dict[str, Any] = panel.snapshot()
            if check(snap):
                return snap
            left = deadline - time.monotonic()
            if left <= 0:
                raise AssertionError(
                    f"timed out; outcome {snap['outcome']}, waiting: {snap['waiting']}"
                )
            changed.wait(left)
    finally:
        cancel()


def waiting_for_operator(snap: dict[str, Any]) -> bool:
    """The arms are done with what they can do; the operator is asked."""
    return (snap["waiting"] or "").startswith("waiting for the operator")


def human_next(panel: Any) -> list[str]:
    return [
        s["next"] for s in panel.snapshot()["suggestions"] if s["owner"] == "human" and s["next"]
    ]


def press_done(panel: Any, action: str) -> None:
    """The operator presses 'done' on ``action``; returns once the panel shows it done."""
    before = panel.snapshot()["events"]
    panel.submit({"action": action})
    until(panel, lambda s: s["events"] > before and action not in _asked(s))


def _asked(snap: dict[str, Any]) -> list[str]:
    return [s["next"] for s in snap["suggestions"] if s["owner"] == "human" and s["next"]]


def finish(panel: Any, timeout: float = 60.0) -> str:
    """The operator presses 'done' on whatever is asked of them, to the end; the outcome."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        snap = until(
            panel,
            lambda s: s["outcome"] != "running" or bool(_asked(s)),
            deadline - time.monotonic(),
        )
        if snap["outcome"] != "running":
            return str(snap["outcome"])
        try:
            press_done(panel, _asked(snap)[0])
        except PanelInputError as exc:  # the arms moved on meanwhile: look again
            assert exc.status == 409, exc
    raise AssertionError("the cooperation did not end")
