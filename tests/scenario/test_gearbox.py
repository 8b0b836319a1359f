"""The gearbox kit (examples/scenarios/gearbox.yaml): a task of a user's own, not the table.

A joint two-arm command (the housing), a part only the left arm reaches (the gear), a step only
the operator may do (greasing), a cover held down by a node process, and two screws that two
agents may fasten at once. It validates clean, is solved under every operator profile and seed,
the profiles give different cooperations, and the in-process cell cooperates as ``run`` does.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from flexhrc import scenario
from flexhrc.cli import main

from ..conftest import REPO, subprocess_env
from .invariants import check_invariants

GEARBOX = REPO / "examples" / "scenarios" / "gearbox.yaml"
PROFILES = ("passive", "takeover", "cooperative", "random")
SEEDS = range(10)


def _run_json(profile: str, seed: int, log: Path, capsys: Any) -> dict[str, Any]:
    code = main(
        ["run", str(GEARBOX), "--human", profile, "--seed", str(seed), "--json", "--quiet",
         "--log", str(log)]
    )  # fmt: skip
    data = json.loads(capsys.readouterr().out)
    assert code == 0 and data["outcome"] == "solved", (profile, seed, data["reason"])
    return data


def _person(data: dict[str, Any]) -> int:
    return int(data["by_agent"]["human"])


def test_validates_clean_and_has_no_table_words() -> None:
    assert scenario.validate(GEARBOX) == []
    # a task of its own: none of the table's words in names, types, actions or comments
    text = GEARBOX.read_text()
    assert not re.search(r"leg|bolt|tabletop", text, re.IGNORECASE)
    sc = scenario.load(GEARBOX)
    assert sc.domain.actions["carry"].agents.names == ("left", "right")  # one joint command
    assert sc.domain.actions["grease"].parameters[0] == ("?who", "human")


@pytest.mark.parametrize("profile", PROFILES)
def test_solved_under_every_profile_and_seed(profile: str, tmp_path: Path, capsys: Any) -> None:
    sc = scenario.load(GEARBOX)
    for seed in SEEDS:
        log = tmp_path / f"{seed}.jsonl"
        data = _run_json(profile, seed, log, capsys)
        events = [json.loads(line) for line in log.read_text().splitlines()]
        check_invariants(sc, events)
        who = {h["hyperarc"]: h["agent"] for h in data["solved_hyperarcs"]}
        assert who["grease_gear"] == "human"  # the operator's alone
        assert who["fit_gear"] in ("left", "human")  # the right arm cannot reach the gear
        assert who.get("arms_mount_housing", "left+right") == "left+right"
        assert set(who) >= {"fasten_1", "fasten_2", "put_cover", "inspect"}


def test_the_right_arm_cannot_reach_the_gear() -> None:
    result = scenario.run(scenario.load(GEARBOX), profile="passive", seed=0)
    decision = next(
        e for e in result.events if e["type"] == "decision" and e["element"] == "fit_gear"
    )
    right = [b for b in decision["branches"] if b["agents"] == ["right"]]
    assert right and not any(b["success"] for b in right)
    assert all("cannot be reached by right" in b["reason"] for b in right)


def test_the_profiles_differ_and_takeover_leaves_the_person_more() -> None:
    sc = scenario.load(GEARBOX)
    runs = {p: [scenario.run(sc, profile=p, seed=s).summary for s in SEEDS] for p in PROFILES}
    person = {p: [_person(s) for s in runs[p]] for p in PROFILES}
    # passive: asked only for what it is needed for (greasing) or best at
    assert sum(person["takeover"]) > sum(person["passive"]), person
    for p in ("cooperative", "random"):
        differs = [
            (a["solved_hyperarcs"], a["by_agent"]) != (b["solved_hyperarcs"], b["by_agent"])
            for a, b in zip(runs[p], runs["passive"], strict=True)
        ]
        assert any(differs), p


def test_two_agents_fasten_the_screws_at_once() -> None:
    """The screws are two nodes joined by one AND hyper-arc: an operator who acts on its own
    fastens one while an arm fastens the other (the cover is held down by the left arm)."""
    result = scenario.run(scenario.load(GEARBOX), profile="takeover", seed=0)
    spans: dict[str, list[float]] = {}
    for e in result.events:
        if (
            e["type"] == "action_end"
            and e["status"] == "done"
            and e["action"].startswith("fasten(")
        ):
            spans[e["action"]] = [e["start"], e["t"]]
    # takeover is first on the step the manager just gave the right arm (issue 22): the arm
    # leaves it and fastens the other screw
    assert set(spans) == {"fasten(human, screw_1)", "fasten(right, screw_2)"}
    (a0, a1), (b0, b1) = spans.values()
    assert a0 < b1 and b0 < a1  # they overlap
    holds = [e for e in result.events if e["type"] == "command" and e.get("process")]
    assert holds and all(e["action"] == "hold(left, cover)" for e in holds)


def _cli(*args: str) -> dict[str, Any]:
    res = subprocess.run(
        [sys.executable, "-m", "flexhrc", *args],
        capture_output=True,
        text=True,
        env=subprocess_env(),
        timeout=120,
    )
    assert res.returncode == 0, res.stderr
    data: dict[str, Any] = json.loads(res.stdout)
    return data


@pytest.mark.parametrize("profile", PROFILES)
def test_the_in_process_cell_cooperates_as_run_does(profile: str) -> None:
    common = ("--json", "--quiet", "--human", profile, "--seed", "0")
    cell = _cli("cell", str(GEARBOX), *common)
    run = _cli("run", str(GEARBOX), *common)
    assert cell["outcome"] == run["outcome"] == "solved"
    order = [(h["hyperarc"], h["agent"]) for h in run["solved_hyperarcs"]]
    assert [(h["hyperarc"], h["agent"]) for h in cell["solved_hyperarcs"]] == order
    assert cell["by_agent"] == run["by_agent"]


def test_every_seed_is_one_cooperation_in_the_cell_command_and_in_run(capsys: Any) -> None:
    """``flexhrc cell`` wires its own in-process agents; its operator is seeded and decides as
    the run's (``operator_seed``; objects chosen when it decides; giving up after thinking): the
    same seed gives the same cooperation, for every profile and the ten seeds."""
    for profile in PROFILES:
        for seed in SEEDS:
            got: dict[str, Any] = {}
            for command in ("cell", "run"):
                args = [command, str(GEARBOX), "--json", "--quiet", "--human", profile]
                assert main([*args, "--seed", str(seed)]) == 0
                got[command] = json.loads(capsys.readouterr().out)
            cell, run = got["cell"], got["run"]
            pairs = [(h["hyperarc"], h["agent"]) for h in run["solved_hyperarcs"]]
            assert [(h["hyperarc"], h["agent"]) for h in cell["solved_hyperarcs"]] == pairs, (
                profile,
                seed,
            )
            assert cell["by_agent"] == run["by_agent"], (profile, seed)
