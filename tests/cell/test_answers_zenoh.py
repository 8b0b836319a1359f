"""Operator answers over Zenoh (issue 22, item 1): the cell's manager and its arm are
`python -m flexhrc` processes; the operator joins over its own Zenoh session (a
:class:`~flexhrc.cell.HumanAgent` with ``replies``, served as `flexhrc agent human` serves it)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("zenoh")

from flexhrc.cell import HumanAgent
from flexhrc.cell.components import execution_model
from flexhrc.cell.serve import serve_until_end, zenoh_for_cell
from flexhrc.scenario import load_scenario

from .helpers import finish, kill_all, robot, rows, start_cell
from .test_answers import LIDS

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("answer", [("cannot", "no gloves"), "ignore"], ids=str)
def test_an_operator_over_zenoh_cannot_or_does_not_answer(tmp_path: Path, answer: Any) -> None:
    path = tmp_path / "lids.yaml"
    path.write_text(LIDS)
    scenario = load_scenario(str(path))
    store = tmp_path / "cell.db"
    manager, port = start_cell(str(path), store, "--answer-timeout", "2", log=tmp_path / "cell.err")
    procs = [manager, robot(str(path), "arm", port, tmp_path / "arm.err")]
    lines: list[str] = []
    try:
        transport = zenoh_for_cell("default", (), (f"tcp/127.0.0.1:{port}",))
        _, outcome = serve_until_end(
            lambda: HumanAgent(
                "human",
                scenario,
                transport,
                execution=execution_model("analytic", scenario),
                trace=lines.append,
                replies=lambda el, actions, k: answer if el == "place_a" else None,
            ),
            transport,
            say=lines.append,
            ready="ready",
        )
        data = finish(procs[0])
    finally:
        kill_all(procs)
    assert outcome == "solved" and data["outcome"] == "solved", (tmp_path / "cell.err").read_text()
    events = rows(store)
    [reply] = [b for _, _, k, b in events if k == "human_reply"]
    [declined] = [b for _, _, k, b in events if k == "human_declined"]
    assert declined["element"] == "place_a"
    if answer == "ignore":  # no answer for 2 s: declined at the request's time + 2
        assert reply["why"] == "timeout" and declined["reply"] == "decline"
        [(t, _)] = [(t, b) for _, t, k, b in events if k == "human_reply"]
        asked = next(t for _, t, k, b in events if k == "suggestion")
        assert t == pytest.approx(asked + 2.0)
    else:
        assert reply["reply"] == "cannot" and declined["reason"] == "no gloves"
    arm = [b["action"] for _, _, k, b in events if k == "command"]
    assert arm[0] == "carry(arm, lid_a, box)"
    assert any("suggestion s1" in line for line in lines)
