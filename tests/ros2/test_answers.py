"""Operator answers over ROS 2 (issue 22, item 1): the manager and the arm are `flexhrc ros2`
nodes; the operator is either the simulated `flexhrc ros2 human --profile reluctant` node (it
answers ``cannot``) or an independent plain-rclpy client (tests/ros2/rclpy_client.py, no flexhrc
code) that gives a step back or never answers (``--answer-timeout``).

The task: two lids onto a box (tests/cell/test_answers.py, the arm named ``left``); the person is
faster, so the manager asks the person first (eq. 21); the arm can do it too. Everything waits on messages and
processes with bounded timeouts, never on fixed sleeps.
"""

from __future__ import annotations

import subprocess
import time
from pathlib import Path
from typing import Any

import pytest

from flexhrc.cell import read_store
from tests.cell.test_answers import LIDS
from tests.ros2.rclpy_client import PlainClient
from tests.ros2.test_cell import _finish, _node, _stop_all

pytestmark = pytest.mark.slow


def _lids(tmp_path: Path) -> Path:
    """The lids task with its arm named ``left``: a ROS 2 arm node streams the joint motions
    of the dual-arm robot model, whose arms are ``left`` and ``right``."""
    path = tmp_path / "lids.yaml"
    path.write_text(LIDS.replace("    arm: {kind: robot", "    left: {kind: robot", 1))
    return path


def _operate(
    client: PlainClient,
    suggestions: list[Any],
    manager: subprocess.Popen[str],
    answer: dict[str, Any] | None,
    timeout: float,
) -> None:
    """The plain operator: to the first request it sends ``answer`` (a ``reply``'s fields;
    None: it never answers it); every later step it carries out (2 s on the cell's clock) and
    reports, until the manager ends."""
    answered: set[tuple[str, int]] = set()
    deadline = time.monotonic() + timeout
    while manager.poll() is None and time.monotonic() < deadline:
        with client.lock:
            todo = [s for s in suggestions if (s["id"], s.get("step", 0)) not in answered]
        for s in todo:
            k = int(s.get("step", 0))
            answered.add((s["id"], k))
            t = float(s["t"])
            if s["id"] == "s1":
                if answer is not None:
                    client.publish("human", {"v": 1, "type": "reply", "id": "plain:s1",
                                             "agent": "human", "suggestion": "s1", "t": t + 0.5,
                                             **answer})  # fmt: skip
                continue
            client.publish("human", {
                "v": 1, "type": "human_action", "id": f"plain:{s['id']}:{k}", "agent": "human",
                "action": s["actions"][k], "suggestion": s["id"], "step": k,
                "start": t, "t": t + 2.0,
            })  # fmt: skip
        time.sleep(0.02)  # polling the client's inbox (a bounded loop, not a wait for time)


def _plain_cell(
    tmp_path: Path,
    ros_env: dict[str, str],
    domain_id: int,
    cell_name: str,
    answer: dict[str, Any] | None,
    *extra: str,
) -> tuple[dict[str, Any], list[Any]]:
    """Manager and arm nodes, the plain operator answering ``answer`` to its first request;
    the manager's --json document and the stored events."""
    common = [str(_lids(tmp_path)), "--cell", cell_name]
    client = PlainClient(cell_name, domain_id)
    suggestions = client.watch("suggest/human")
    client.tokens.append("alive/human")
    procs: list[subprocess.Popen[str]] = []
    store = tmp_path / "c.db"
    try:
        procs.append(_node(ros_env, "cell", *common, "--json", "--store", str(store), *extra,
                           log=tmp_path / "manager.log"))  # fmt: skip
        procs.append(_node(ros_env, "arm", *common, "--arm", "left", log=tmp_path / "arm.log"))
        _operate(client, suggestions, procs[0], answer, 120.0)
        data = _finish(procs[0], 30, tmp_path)
    finally:
        client.close()
        _stop_all(procs)
    assert data["outcome"] == "solved", data.get("reason")
    return data, read_store(store)


def test_a_step_the_plain_operator_gives_back_is_done_by_the_arm(
    tmp_path: Path, ros_env: dict[str, str], domain_id: int, cell_name: str
) -> None:
    _, events = _plain_cell(tmp_path, ros_env, domain_id, cell_name, {"reply": "give_back"})
    [reply] = [e for e in events if e.kind == "human_reply"]
    assert reply.body["reply"] == "give_back" and reply.body["suggestion"] == "s1"
    [declined] = [e for e in events if e.kind == "human_declined"]
    assert declined.body["reply"] == "give_back" and declined.body["element"] == "place_a"
    [cmd] = [e for e in events if e.kind == "command" and e.body["element"] == "place_a"]
    assert cmd.body["action"] == "carry(left, lid_a, box)"
    assert cmd.t == declined.t == reply.t  # the arm gets it at the give-back, not later


def test_a_request_nobody_answers_over_ros2_is_declined_after_the_timeout(
    tmp_path: Path, ros_env: dict[str, str], domain_id: int, cell_name: str
) -> None:
    """The operator holds its token but never answers its first request: with
    ``--answer-timeout 2`` the manager stores a declined reply (``why: timeout``) 2 s after the
    request, and the arm carries the lid from then on."""
    _, events = _plain_cell(tmp_path, ros_env, domain_id, cell_name, None, "--answer-timeout", "2")
    [asked] = [e for e in events if e.kind == "suggestion" and e.body["element"] == "place_a"]
    [reply] = [e for e in events if e.kind == "human_reply"]
    assert reply.body["reply"] == "decline" and reply.body["why"] == "timeout"
    assert reply.t == pytest.approx(asked.t + 2.0)
    [declined] = [e for e in events if e.kind == "human_declined"]
    assert (
        declined.body["element"] == "place_a" and "no answer after 2 s" in declined.body["reason"]
    )
    [cmd] = [e for e in events if e.kind == "command" and e.body["element"] == "place_a"]
    assert cmd.body["agents"] == ["left"] and cmd.t == pytest.approx(asked.t + 2.0)


def test_the_reluctant_operator_node_answers_cannot_and_is_never_asked_again(
    tmp_path: Path, ros_env: dict[str, str], cell_name: str
) -> None:
    """`flexhrc ros2 human --profile reluctant`: the simulated operator node answers as the
    in-process one does (the same :class:`~flexhrc.cell.HumanAgent` and profile): ``cannot``
    carry, its reason stored; the branch is never offered to it again and the arm carries both
    lids."""
    common = [str(_lids(tmp_path)), "--cell", cell_name]
    store = tmp_path / "c.db"
    procs: list[subprocess.Popen[str]] = []
    try:
        procs.append(_node(ros_env, "cell", *common, "--json", "--store", str(store),
                           log=tmp_path / "manager.log"))  # fmt: skip
        procs.append(_node(ros_env, "arm", *common, "--arm", "left", log=tmp_path / "arm.log"))
        procs.append(_node(ros_env, "human", *common, "--name", "human", "--profile",
                           "reluctant", "--json", log=tmp_path / "human.log"))  # fmt: skip
        data = _finish(procs[0], 120, tmp_path)
        assert procs[2].wait(30) == 0, (tmp_path / "human.log").read_text()[-2000:]
    finally:
        _stop_all(procs)
    assert data["outcome"] == "solved", data.get("reason")
    events = read_store(store)
    replies = [e.body for e in events if e.kind == "human_reply"]
    assert replies and {r["reply"] for r in replies} == {"cannot"}, replies
    [declined] = [e.body for e in events if e.kind == "human_declined"]
    assert declined["element"] == "place_a" and declined["reason"] == replies[0]["reason"]
    assert "carry" in declined["reason"]
    asked = [e.body["element"] for e in events if e.kind == "suggestion"]
    assert asked == ["place_a"]  # never asked again after its cannot
    carried = [e.body["agents"] for e in events if e.kind == "command"]
    assert carried == [["left"], ["left"]], carried
