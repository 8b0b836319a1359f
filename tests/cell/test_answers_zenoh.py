"""Operator answers over Zenoh (issue 22, item 1): the cell's manager and its arm are
`python -m flexhrc` processes; the operator joins over its own Zenoh session (a
:class:`~flexhrc.cell.HumanAgent` with ``replies``, served as `flexhrc agent human` serves it):
in this process, as its own `flexhrc agent human --profile reluctant` process, or as its own
process answering from a script (``scripted_operator.py``: decline, give_back, start)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("zenoh")

from flexhrc.cell import HumanAgent
from flexhrc.cell.components import execution_model
from flexhrc.cell.replay import replay
from flexhrc.cell.serve import serve_until_end, zenoh_for_cell
from flexhrc.scenario import load_scenario
from flexhrc.taskmanager.timeline import intervals

from ..conftest import subprocess_env
from .helpers import finish, human, kill_all, robot, rows, start_cell
from .test_answers import LIDS

pytestmark = pytest.mark.slow

OPERATOR = Path(__file__).with_name("scripted_operator.py")


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


def _operator(path: Path, port: int, log: Path, *script: str) -> subprocess.Popen[str]:
    """The operator as its own process (tests/cell/scripted_operator.py: the simulated
    operator of `flexhrc agent human`, answering from ``script``)."""
    return subprocess.Popen(
        [sys.executable, str(OPERATOR), str(path), f"tcp/127.0.0.1:{port}", *script],
        stdout=subprocess.PIPE, stderr=open(log, "w"), text=True, env=subprocess_env(),
    )  # fmt: skip


def _run_with_an_operator_process(
    tmp_path: Path, *script: str
) -> list[tuple[int, float, str, dict[str, Any]]]:
    """The lids cell: the manager, the arm and the scripted operator, three processes; the
    store's rows once the cell has ended solved and the operator has exited."""
    path = tmp_path / "lids.yaml"
    path.write_text(LIDS)
    store = tmp_path / "cell.db"
    manager, port = start_cell(str(path), store, log=tmp_path / "cell.err")
    procs = [manager, robot(str(path), "arm", port, tmp_path / "arm.err")]
    try:
        procs.append(_operator(path, port, tmp_path / "human.err", *script))
        data = finish(manager, timeout=120)
        out, _ = procs[2].communicate(timeout=30)
    finally:
        kill_all(procs)
    logs = {p.name: p.read_text()[-1500:] for p in tmp_path.glob("*.err")}
    assert data["outcome"] == "solved", logs
    assert procs[2].returncode == 0 and out.strip() == "solved", logs
    return rows(store)


@pytest.mark.parametrize("answer", ["decline", "give_back"])
def test_an_operator_process_declines_or_gives_back_and_the_arm_does_it(
    tmp_path: Path, answer: str
) -> None:
    """The operator's own process says "not now" (or gives the step back) to its first
    request: the manager stores the reply and the arm carries the first lid at once."""
    events = _run_with_an_operator_process(tmp_path, f"place_a={answer}")
    [reply] = [b for _, _, k, b in events if k == "human_reply"]
    assert reply["reply"] == answer and reply["suggestion"] == "s1"
    [declined] = [(t, b) for _, t, k, b in events if k == "human_declined"]
    assert declined[1]["element"] == "place_a" and declined[1]["reply"] == answer
    [asked] = [(t, b) for _, t, k, b in events if k == "suggestion" and b["element"] == "place_a"]
    assert declined[0] == pytest.approx(asked[0] + 1.0)  # REPLY_S after the request
    [(t, cmd)] = [(t, b) for _, t, k, b in events if k == "command" and b["element"] == "place_a"]
    assert cmd["action"] == "carry(arm, lid_a, box)" and t == declined[0]  # at the "not now"
    done = [b for _, _, k, b in events if k == "ack" and b["status"] == "done"]
    assert [b["agent"] for b in done] == ["arm", "arm"]  # as in one process (test_answers)
    assert not [b for _, _, k, b in events if k == "human_action"]


def test_an_operator_process_says_it_starts_and_replay_and_the_lane_show_its_time(
    tmp_path: Path,
) -> None:
    """The operator says "I'm starting" before each step and reports it without a start: the
    store's reports carry the start it said, `flexhrc replay` counts the person's time and the
    timeline's human lane has both lids."""
    events = _run_with_an_operator_process(tmp_path, "*=start")
    starts = [(b["suggestion"], t) for _, t, k, b in events
              if k == "human_reply" and b["reply"] == "start"]  # fmt: skip
    reports = [(b, t) for _, t, k, b in events if k == "human_action"]
    assert [s for s, _ in starts] == ["s1", "s2"] and len(reports) == 2
    assert all(
        b["start"] == round(s, 6) < t for (b, t), (_, s) in zip(reports, starts, strict=True)
    )
    plot = tmp_path / "timeline.svg"
    shown = subprocess.run(
        [sys.executable, "-m", "flexhrc", "replay", str(tmp_path / "cell.db"), "--json",
         "--plot", str(plot)],
        capture_output=True, text=True, env=subprocess_env(), timeout=120,
    )  # fmt: skip
    assert shown.returncode == 0, shown.stderr
    timing = json.loads(shown.stdout)["timing"]
    assert timing["human_actions_s"] == pytest.approx(4.141421, abs=1e-5)  # as in one process
    assert plot.stat().st_size > 0
    lane = [i for i in intervals(replay(tmp_path / "cell.db").events) if i["agent"] == "human"]
    assert [i["action"] for i in lane] == ["carry(human, lid_a, box)", "carry(human, lid_b, box)"]
    assert [i["end"] - i["start"] for i in lane] == [pytest.approx(2.141421), pytest.approx(2.0)]
