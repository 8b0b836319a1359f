"""A utility a user can shape (issue 22, item 2): each term flips a decision when its weight
changes; the default is the paper's eq. (21); bad keys are one FILE:LINE error."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from flexhrc.cli import main
from flexhrc.scenario import load_scenario
from flexhrc.scenario.run import run
from flexhrc.taskmanager.utility import Utility

#: one bolt three agents can screw: the left arm is nearest (fastest), the right arm is slowest,
#: the person's hand is at HX (1.2: a little slower than the left arm; 0.5: the fastest)
SCREW = """\
flexhrc: 1
name: screw_choice
graphs:
  screw_task:
    root: fixed
    nodes:
      - {name: loose, state: "loose(bolt)"}
      - {name: fixed, state: "tight(bolt)"}
    hyperarcs:
      - name: screw_bolt
        children: [loose]
        parent: fixed
        weight: 1
        actions: ["screw(?who, bolt)"]
domain:
  agents:
    human: {kind: human, types: [human], hand: [HX, 0.0, 0.1]}
    left: {kind: robot, types: [arm], base: [0.0, 0.3, 0.4], rest: [0.3, 0.3, 0.5], reach: 0.9}
    right: {kind: robot, types: [arm], base: [0.0, -0.3, 0.4], rest: [0.3, -0.3, 0.5], reach: RR}
  actions:
    screw:
      parameters: {"?who": agent, "?b": bolt}
      agents: {choice: "?who"}
      pre: ["loose(?b)"]
      add: ["tight(?b)"]
      delete: ["loose(?b)"]
      moves_to: "?b"
      duration: 1.0
world:
  objects:
    bolt: {type: bolt, position: [0.45, 0.25, 0.0], size: [0.02, 0.02, 0.02]}
  facts: ["loose(bolt)"]
humans:
  - {name: human, profile: passive, speed: 0.6}
"""


def _scenario(tmp_path: Path, utility: str = "", hx: str = "1.2", reach: str = "0.9") -> Path:
    path = tmp_path / "screw.yaml"
    text = SCREW.replace("HX", hx).replace("RR", reach)
    path.write_text(text + (f"utility: {utility}\n" if utility else ""), encoding="utf-8")
    return path


def _first_decision(tmp_path: Path, utility: str = "", **kw: str) -> tuple[str, dict[str, Any]]:
    """Who the first decision chose, and that decision's log event."""
    result = run(load_scenario(_scenario(tmp_path, utility, **kw)), seed=0)
    decision = next(e for e in result.events if e.get("type") == "decision")
    chosen = decision["branches"][decision["chosen"]]
    return chosen["agents"][0], decision


def test_the_default_is_eq_21_and_logs_no_terms(tmp_path):
    who, decision = _first_decision(tmp_path)
    assert who == "left"  # the fastest: J = success / time
    assert all("terms" not in b for b in decision["branches"])
    for b in decision["branches"]:
        assert b["utility"] == pytest.approx(1.0 / sum(b["durations"]))
    # the default weights written out are eq. (21) too: the same decision, terms logged
    who, decision = _first_decision(tmp_path, "{success: 1, time: 1, preference: 0}")
    assert who == "left"
    for b in decision["branches"]:
        assert b["terms"]["utility"] == pytest.approx(1.0 / sum(b["durations"]))
        assert set(b["terms"]) == {"success", "time", "preference", "workload", "utility"}
    assert Utility().is_default


def test_preference_weight_flips_prefer_the_right_arm_for_screwing(tmp_path):
    prefer = "prefer: {screw: {right: 1}}"
    assert _first_decision(tmp_path, f"{{preference: 0, {prefer}}}")[0] == "left"
    who, decision = _first_decision(tmp_path, f"{{preference: 1, {prefer}}}")
    assert who == "right"
    right = next(b for b in decision["branches"] if b["agents"] == ["right"])
    assert right["terms"]["preference"] == 1.0


def test_preference_by_agent_kind(tmp_path):
    # a per-agent preference: any person, every action
    assert _first_decision(tmp_path, "{preference: 0, prefer: {human: 1}}")[0] == "left"
    assert _first_decision(tmp_path, "{preference: 1, prefer: {human: 1}}")[0] == "human"


def test_time_weight_flips(tmp_path):
    # a slight preference for the slow right arm: time decides while it weighs
    prefer = "preference: 1, prefer: {right: 0.1}"
    assert _first_decision(tmp_path, f"{{time: 1, {prefer}}}")[0] == "left"
    assert _first_decision(tmp_path, f"{{time: 0, {prefer}}}")[0] == "right"


def test_workload_weight_flips(tmp_path):
    # the person's hand is nearest: eq. (21) asks the person; the workload term spares them
    assert _first_decision(tmp_path, "{workload: 0}", hx="0.5")[0] == "human"
    who, decision = _first_decision(tmp_path, "{workload: 5}", hx="0.5")
    assert who == "left"
    person = next(b for b in decision["branches"] if b["agents"] == ["human"])
    assert person["terms"]["workload"] == 1.0  # all the busy time would be the person's
    # a cap on the person's share excludes their branch as well
    assert _first_decision(tmp_path, "{max_workload: 0.4}", hx="0.5")[0] == "left"


def test_effort_weighs_the_persons_time(tmp_path):
    u = Utility(workload=1.0, effort={"screw": 2.0})
    scenario = load_scenario(_scenario(tmp_path, hx="0.5"))
    from flexhrc.taskmanager.domain import GroundAction

    schema = scenario.domain.actions["screw"]
    step = GroundAction(schema, ("human", "bolt"), ("human",))
    terms = u.terms([step], True, [2.0], scenario.domain, now=2.0, person_time={"human": 0.0})
    assert terms["workload"] == pytest.approx(4.0 / 4.0)
    light = Utility(workload=1.0).terms([step], True, [2.0], scenario.domain, now=2.0)
    assert light["workload"] == pytest.approx(2.0 / 4.0)
    assert terms["utility"] < light["utility"]


def test_success_weight_flips(tmp_path):
    # the right arm cannot reach the bolt (the simulator says it fails); time left out, the
    # right arm preferred: with success weighed it is never chosen, without it is
    base = "time: 0, preference: 1, prefer: {right: 1}"
    assert _first_decision(tmp_path, f"{{success: 1, {base}}}", reach="0.2")[0] != "right"
    assert _first_decision(tmp_path, f"{{success: 0, {base}}}", reach="0.2")[0] == "right"


@pytest.mark.parametrize(
    ("block", "needle", "message"),
    [
        ("{speed: 1}", "utility:", "utility: unknown key 'speed'"),
        ("{time: -1}", "utility:", "utility: time must be a number >= 0, got -1"),
        ("{prefer: {screw: {nobody: 1}}}", "utility:", "utility: prefer: screw: 'nobody' names no"),
        ("{prefer: {grease: {left: 1}}}", "utility:", "utility: prefer: 'grease' is not an action"),
        ("{effort: {screw: yes}}", "utility:", "utility: effort: screw must be a number >= 0"),
        ("{max_workload: 1.5}", "utility:", "utility: max_workload must be a share between 0"),
        ("[1, 2]", "utility:", "utility must be a mapping"),
    ],
)
def test_bad_utility_is_one_file_line_error(tmp_path, capsys, block, needle, message):
    path = _scenario(tmp_path, block)
    code = main(["scenario", "validate", str(path)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1, err
    line = 1 + path.read_text().splitlines().index(f"utility: {block}")
    assert err[0].startswith(f"{path}:{line}: {message}"), err


def test_json_shows_each_branchs_terms(tmp_path, capsys):
    import json

    path = _scenario(tmp_path, "{preference: 1, prefer: {screw: {right: 1}}}")
    assert main(["run", str(path), "--json"]) == 0
    out = capsys.readouterr().out
    data = json.loads(out[out.index("{") :])
    (decision,) = data["decision_terms"]
    assert decision["element"] == "screw_bolt"
    chosen = decision["branches"][decision["chosen"]]
    assert chosen["agents"] == ["right"]
    assert chosen["terms"]["preference"] == 1.0
    assert {tuple(b["agents"]) for b in decision["branches"]} == {("human",), ("left",), ("right",)}
    # without a utility block the summary is as before
    assert main(["run", str(_scenario(tmp_path)), "--json"]) == 0
    out = capsys.readouterr().out
    assert "decision_terms" not in json.loads(out[out.index("{") :])


def test_the_utility_is_part_of_the_scenarios_fingerprint(tmp_path):
    from flexhrc.cell import identity

    plain = load_scenario(_scenario(tmp_path))
    (tmp_path / "b").mkdir()
    (tmp_path / "c").mkdir()
    shaped = load_scenario(_scenario(tmp_path / "b", "{workload: 1}"))
    other = load_scenario(_scenario(tmp_path / "c", "{workload: 2}"))
    prints = {identity.fingerprint(s) for s in (plain, shaped, other)}
    assert len(prints) == 3
