"""Perception closes the loop (issue 13): the manager knows the world only through its sensors.

Each run is the cell configured with perception in the loop (:mod:`flexhrc.sensing.loop`, issue
19): in-process arms and operators over the ordered bus, the head camera's perception agent a
watcher of the loop. Runs use the analytic simulator for speed (the kinematic one:
``test_kinematic_run`` and the CLI); perception — PyBullet depth, the scene pipeline,
anchoring — is the real thing.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys

import pytest

pytest.importorskip("pybullet")
pytest.importorskip("scipy")

from flexhrc.sensing.loop import FalseReport, Nudge
from flexhrc.sensing.setup import perceived_run
from flexhrc.taskmanager import AnalyticSimulator
from flexhrc.taskmanager.operator import PROFILES

from ..conftest import subprocess_env
from .conftest import table


def run_table(profile="passive", seed=0, *, kinematic=False, watch=False, shipped=False, **kw):
    """A perceived run of the legs fix (``shipped``: the shipped ``table_assembly`` scenario,
    all three segments, as ``flexhrc run table_assembly --perception scene`` runs it)."""
    if not kinematic:
        kw.setdefault("simulator", AnalyticSimulator())
    if shipped:
        from flexhrc.scenario import load

        sc = load("table_assembly")
        graph, domain, truth = sc.online_graph(), sc.domain, sc.world()
        kw.setdefault("humans", [(h.name, profile) for h in sc.humans])
    else:
        sc, truth = table(seed)
        graph, domain = sc.online_graph(), sc.domain
    run = perceived_run(graph, domain, truth, human_profile=profile, seed=seed, **kw)
    frames: list[dict[str, str]] = []
    if watch:  # which physical part each anchored symbol sits on, frame by frame
        update = run.perception.update

        def watched(now, rgb=False):
            upd = update(now, rgb=rgb)
            on = {}
            for sym in upd.report.anchored:
                pos = run.perception.anchoring.kb.position(sym)
                part = min(
                    run.world.parts.values(), key=lambda p: math.dist(p.position[:2], pos[:2])
                )
                on[sym] = part.name
            frames.append(on)
            return upd

        run.perception.update = watched
    result = run.run()
    run.perception.close()
    return result, run, frames


def kinds(result, *types):
    return [e for e in result.events if e["type"] in types]


@pytest.mark.slow
@pytest.mark.parametrize("shipped", [True, False], ids=["table_assembly", "legs_fix"])
@pytest.mark.parametrize("profile", PROFILES)
def test_no_positions_given_solved_for_every_profile_and_5_seeds_with_stable_symbols(
    profile, shipped
):
    for seed in range(5):
        result, _run, frames = run_table(profile, seed, watch=True, shipped=shipped)
        assert result.outcome == "solved", (profile, seed, result.reason)
        p = result.summary["perception"]
        assert p["new_objects"] == [] and p["inconsistencies"] == 0, (profile, seed, p)
        assert set(p["symbols"]) == {"leg1", "leg2", "leg3", "leg4", "tabletop"}
        # every leg and the tabletop stays anchored to one and the same part all run long
        sym_part: dict[str, str] = {}
        for on in frames:
            for sym, part in on.items():
                assert sym_part.setdefault(sym, part) == part, (profile, seed, sym)
        assert len(set(sym_part.values())) == len(sym_part) == 5
        assert p["frames"] == len(frames) >= 8  # the start, then after every change


def test_the_manager_starts_without_positions_and_perception_runs_after_world_changes():
    result, _run, _ = run_table("passive", 0)
    assert result.outcome == "solved"
    percepts = kinds(result, "percept")
    whys = [e["why"] for e in percepts if "why" in e]
    assert whys[0] == "start"
    assert not any(w.startswith(("after approach", "after rest")) for w in whys)
    assert any(w.startswith("after transport") for w in whys)
    s = result.summary
    assert set(s["perception"]) >= {
        "frames", "anchored", "new_objects", "missing", "inconsistencies", "repaired"
    }  # fmt: skip
    assert set(s["human_sensing"]) >= {"performed", "recognised", "missed", "false_reports"}


def test_the_same_seed_gives_the_same_run():
    # the percepts are inputs at well-defined times (the camera is a watcher of the ordered
    # loop): two runs agree event for event
    def trace(result):
        keep = ("type", "t", "object", "moved", "why", "action", "element", "status", "command")
        return [{k: e[k] for k in keep if k in e} for e in result.events if e["type"] != "summary"]

    nudge = [Nudge("approach", 1, (0.0, 0.08), 0.5)]
    first, _, _ = run_table("cooperative", 2, nudges=nudge)
    again, _, _ = run_table("cooperative", 2, nudges=nudge)
    assert first.outcome == "solved", first.reason
    assert [e for e in trace(first) if e["type"] == "percept"]
    assert trace(first) == trace(again)


def test_operator_moves_a_leg_while_the_robot_goes_to_grasp_it():
    result, run, _ = run_table("passive", 0, nudges=[Nudge("approach", 1, (0.0, 0.08), 0.5)])
    assert result.outcome == "solved", result.reason
    nudge = kinds(result, "operator_nudges")[0]
    after = result.events[result.events.index(nudge) :]
    # one percept per object: the one of the part seen away from the belief says it moved
    percept = next(e for e in after if e["type"] == "percept" and e.get("moved"))
    leg = percept["object"]
    stop = next(e for e in after if e["type"] == "stop")
    assert stop["reason"] == f"{leg} moved" and stop["command"] == 1  # the first approach
    ended = next(e for e in after if e["type"] == "action_end" and e["command"] == 1)
    assert ended["status"] == "stopped" and ended["action"].startswith("approach")
    # re-anchored where the operator put it, re-planned from there
    part = run.world.part(nudge["part"])
    replanned = next(e for e in after if e["type"] == "decision")
    assert replanned["t"] == nudge["t"]
    assert not kinds(result, "action_failed")  # nobody grasped thin air
    grasps = [e for e in kinds(result, "action_end") if e["action"].startswith("grasp")]
    assert all(g["status"] == "done" for g in grasps)
    assert part.fixed  # the nudged leg was fetched from its new place and screwed in


def test_a_false_report_makes_the_base_inconsistent_and_the_manager_waits():
    result, _run, _ = run_table("passive", 0, false_reports=[FalseReport("rest", 1)])
    inc = kinds(result, "inconsistent")
    assert inc and "should be at" in inc[0]["reason"]
    assert kinds(result, "waiting")
    # nothing clears it (nobody did it): the run ends, failed, and says why; never waits for ever
    assert result.outcome == "failed"
    assert "inconsistent" in result.reason and "deadlock" in result.reason
    assert result.summary["human_sensing"]["false_reports"] == 1


def test_with_repair_the_manager_repairs_first_then_solves():
    result, _run, _ = run_table("passive", 0, false_reports=[FalseReport("rest", 1)], repair=True)
    assert result.outcome == "solved", result.reason
    events = result.events
    i = next(k for k, e in enumerate(events) if e["type"] == "inconsistent")
    j = next(k for k, e in enumerate(events) if e["type"] == "repaired")
    between = events[i:j]
    steps = [e["step"] for e in between if e["type"] == "repair"]
    assert steps == ["re-perceive", "ask operator"]
    assert any(e["type"] == "operator_answers" and e["answer"] == "no" for e in between)
    # no new task decision or command while repairing (rests of stopped arms aside)
    assert not [e for e in between if e["type"] == "decision"]
    assert not [e for e in between if e["type"] == "command" and not e["action"].startswith("rest")]
    assert events[j]["object"] in events[i]["reason"]
    assert result.summary["perception"]["repaired"] == 1


def test_the_next_compatible_percept_clears_an_inconsistency():
    from flexhrc.sensing.loop import forget_positions
    from flexhrc.sensing.perception import PerceptionComponent
    from flexhrc.sensing.world import SimulatedWorkspace

    _, truth = table(0)
    world, _names = SimulatedWorkspace.from_knowledge(truth, types=["leg", "tabletop"])
    kb = forget_positions(truth, ["leg", "tabletop"])
    comp = PerceptionComponent(world, kb)
    try:
        comp.update(0.0)
        leg = "leg2"
        seen = kb.position(leg)
        kb.move(leg, world.hand)  # the belief a report of pick_up(human, leg2) implies
        comp.anchoring.expect(leg)  # a report: the next percept checks it
        rep = comp.update(1.0).report
        assert rep.inconsistencies and not kb.consistent
        world.pick_up("human", seen)  # the operator really takes it (the report was early)
        rep = comp.update(2.0).report
        assert rep.cleared == [leg] and kb.consistent
    finally:
        comp.close()


@pytest.mark.slow
def test_kinematic_run():
    result, _, _ = run_table("cooperative", 1, kinematic=True)
    assert result.outcome == "solved", result.reason
    assert result.summary["perception"]["new_objects"] == []


def cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "flexhrc", *args],
        capture_output=True,
        text=True,
        env=subprocess_env(),
        timeout=600,
    )


def test_cli_perception_scene_json():
    out = cli(
        "demo", "table", "--perception", "scene", "--simulator", "analytic",
        "--human", "takeover", "--json", "--quiet",
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)  # stdout is JSON only (pybullet's banner kept off it)
    assert data["outcome"] == "solved"
    assert data["perception"]["frames"] >= 5 and data["perception"]["anchored"] == 5
    assert data["perception"]["mode"] == "scene"
    assert data["human_sensing"]["performed"] == data["human_sensing"]["recognised"] > 0


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--repair"], "--repair needs --perception scene"),
        (["--human-sensing", "har-real"], "needs --hmp"),
        (["--hmp", "/nonexistent"], "--hmp goes with"),
        (["--human-sensing", "har-real", "--hmp", "/nonexistent"], "not a directory"),
    ],
)
def test_cli_option_errors(args, message):
    out = cli("demo", "table", "--simulator", "analytic", "--quiet", *args)
    assert out.returncode == 2 and message in out.stderr and "Traceback" not in out.stderr


def test_bad_run_arguments_are_refused():
    from flexhrc.errors import FlexhrcError

    with pytest.raises(FlexhrcError, match="no such action"):
        run_table("passive", 0, false_reports=[FalseReport(action="juggle")])
    with pytest.raises(FlexhrcError, match="nth >= 1"):
        Nudge(nth=0)
    with pytest.raises(FlexhrcError, match="finite"):
        Nudge(offset=(float("nan"), 0.0))
    with pytest.raises(FlexhrcError, match="confirm_s"):
        run_table("passive", 0, confirm_s=float("inf"))


def test_cli_run_table_assembly_perception_scene():
    out = cli("run", "table_assembly", "--perception", "scene", "--json", "--quiet")
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    assert data["scenario"] == "table_assembly" and data["outcome"] == "solved"
    assert data["cell"]["name"] == "table_assembly"  # the cell takes the scenario's name
    p = data["perception"]
    for key in ("frames", "anchored", "new_objects", "missing", "inconsistencies", "repaired"):
        assert key in p
    assert p["anchored"] == 5 and p["new_objects"] == [] and p["inconsistencies"] == 0
    hs = data["human_sensing"]
    assert {"performed", "recognised", "missed", "false_reports"} <= set(hs)


def test_cli_run_given_keeps_its_keys_and_a_wrist_sensor_adds_its_figures():
    plain = json.loads(cli("run", "table_assembly", "--json", "--quiet").stdout)
    assert "perception" not in plain and "human_sensing" not in plain  # as the cell's summary
    out = cli("run", "table_assembly", "--human-sensing", "har", "--json", "--quiet")
    assert out.returncode == 0, out.stderr
    hs = json.loads(out.stdout)["human_sensing"]
    assert hs["mode"] == "har" and hs["uncovered"] == 4  # the operator's checks
    assert hs["performed"] == hs["recognised"] + hs["missed"] + hs["false_reports"]


def test_a_perception_log_replays(tmp_path):
    log = tmp_path / "run.jsonl"
    out = cli(
        "run", "table_assembly", "--perception", "scene", "--log", str(log), "--json", "--quiet"
    )
    assert out.returncode == 0, out.stderr
    kinds = {json.loads(line)["type"] for line in log.read_text().splitlines()}
    assert "percept" in kinds
    again = cli("replay", str(log), "--json")
    assert again.returncode == 0, again.stderr
    assert json.loads(again.stdout)["outcome"] == "solved"


def test_cli_scene_frame(tmp_path):
    png = tmp_path / "frame.png"
    out = cli("scene", "frame", "-o", str(png), "--json")
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert data["detections"] >= 4 and "tabletop" in data["anchored"]
    bad = cli("scene", "frame", "-o", str(tmp_path / "frame.jpg"))
    assert bad.returncode == 2 and ".png" in bad.stderr and "Traceback" not in bad.stderr
