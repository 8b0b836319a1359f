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

from .helpers import finish, human, kill_all, robot, rows, start_cell
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


def test_a_reluctant_operator_process_answers_cannot_and_the_arm_does_it(tmp_path: Path) -> None:
    """The operator as its own `flexhrc agent human --profile reluctant` process: the only
    action of the lids task, `carry`, is one an arm may also do, so the profile answers
    `cannot` when asked (its seeded share is at least one such action); the manager stores the
    reply, never asks the person again, and the arm carries both lids."""
    path = tmp_path / "lids.yaml"
    path.write_text(LIDS)
    store = tmp_path / "cell.db"
    manager, port = start_cell(str(path), store, log=tmp_path / "cell.err")
    procs = [manager, robot(str(path), "arm", port, tmp_path / "arm.err")]
    try:
        procs.append(
            human(str(path), "human", port, tmp_path / "human.err", "--profile", "reluctant")
        )
        data = finish(manager, timeout=120)
        assert procs[2].wait(30) == 0, (tmp_path / "human.err").read_text()[-2000:]
    finally:
        kill_all(procs)
    assert data["outcome"] == "solved", (tmp_path / "cell.err").read_text()[-2000:]
    events = rows(store)
    replies = [b for _, _, k, b in events if k == "human_reply"]
    assert replies and {b["reply"] for b in replies} == {"cannot"}, replies
    assert [b["element"] for _, _, k, b in events if k == "human_declined"] == ["place_a"]
    asked = [b for _, _, k, b in events if k == "suggestion"]
    assert len(asked) == 1, asked  # never asked again after its cannot
    carried = [b["agents"] for _, _, k, b in events if k == "command"]
    assert carried == [["arm"], ["arm"]], carried
