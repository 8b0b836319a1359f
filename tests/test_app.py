"""`flexhrc.app`: each of `run`, `demo table` and `replay` as one library call (issue 19, item 6).

The report of :func:`run_scenario` is what the command prints: its ``json`` is the command's
``--json`` document key for key (the wall-clock compute times aside, which no two runs share),
its ``text`` the command's output; a bad config is one error naming the option.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from flexhrc.app import ReplayReport, RunConfig, RunReport, TableDemo, replay, run_scenario
from flexhrc.app.run import trace_line
from flexhrc.cli import main
from flexhrc.errors import FlexhrcError

COMPUTE = ("task_manager_s", "task_representation_s", "simulator_s")


def _steady(doc: dict) -> dict:
    """``doc`` without what the wall clock decides (compute times, ``wall_s``)."""
    doc = json.loads(json.dumps(doc))  # tuples as lists, as the command prints them
    doc.pop("wall_s", None)
    for key in COMPUTE:
        doc["timing"].pop(key)
    doc.get("perception", {}).pop("update_ms_median", None)
    doc.get("perception", {}).pop("compute_s", None)
    return doc


def _cli_json(capsys, argv: list[str]) -> tuple[int, dict]:
    code = main([*argv, "--json", "--quiet"])
    return code, json.loads(capsys.readouterr().out)


@pytest.mark.parametrize(
    ("argv", "config"),
    [
        (
            ["run", "ball_in_box", "--human", "takeover", "--seed", "3", "--fail", "pick:1"],
            RunConfig("ball_in_box", human="takeover", seed=3, fail=("pick:1",)),
        ),
        (
            ["run", "table_assembly", "--segments", "legs", "--human-takes", "2"],
            RunConfig("table_assembly", segments="legs", human_takes=(2,)),
        ),
        (
            ["demo", "table", "--legs", "3", "--no-human", "--simulator", "analytic"],
            RunConfig(TableDemo(legs=3, human=False), simulator="analytic"),
        ),
    ],
    ids=["shipped", "segments", "demo-table"],
)
def test_the_report_is_the_commands_json(capsys, argv, config):
    code, printed = _cli_json(capsys, argv)
    report = run_scenario(dataclasses.replace(config, quiet=True))
    assert isinstance(report, RunReport)
    assert list(report.json) == list(printed)  # the same keys in the same order
    assert _steady(report.json) == _steady(printed)
    assert report.exit_code == code == 0 and report.result.outcome == "solved"


def test_a_run_json_names_the_scenario_first_and_a_demo_table_speaks_of_legs():
    demo = run_scenario(RunConfig(TableDemo(legs=1), segments="legs", quiet=True))
    run = run_scenario(RunConfig("table_assembly", segments="legs", quiet=True))
    assert next(iter(demo.json)) == "outcome" and "legs_by_agent" in demo.json
    assert next(iter(run.json)) == "scenario"


def test_the_report_text_is_what_the_command_prints(capsys, tmp_path):
    log = tmp_path / "run.jsonl"
    assert main(["run", "ball_in_box", "--seed", "1", "--quiet", "--log", str(log)]) == 0
    printed = capsys.readouterr().out
    report = run_scenario(RunConfig("ball_in_box", seed=1, quiet=True, log=str(log)))
    steady = [
        ln for ln in printed.splitlines() if not ln.startswith(("Task ", "Simulator ", "Compute"))
    ]
    assert [ln for ln in report.text.splitlines() if ln in steady] == steady
    assert report.text.splitlines()[-1] == f"event log: {log}"


def test_the_trace_sees_every_event_and_speaks_the_commands_lines():
    seen: list[dict] = []
    report = run_scenario(RunConfig("ball_in_box", quiet=True), trace=seen.append)
    assert seen == report.result.events
    lines = [line for ev in seen if (line := trace_line(ev)) is not None]
    assert lines[-1].endswith("outcome: SOLVED")
    assert any(" decide " in line for line in lines)
    assert trace_line({"type": "start", "t": 0.0}) is None


def test_perception_in_the_loop_is_a_config_too(capsys):
    pytest.importorskip("pybullet")
    pytest.importorskip("scipy")
    argv = ["demo", "table", "--legs", "2", "--segments", "legs", "--perception", "scene"]
    _, printed = _cli_json(capsys, argv)
    config = RunConfig(TableDemo(legs=2), segments="legs", perception="scene", quiet=True)
    report = run_scenario(config)
    assert report.json["perception"]["mode"] == "scene"
    assert report.json["human_sensing"]["mode"] == "injected"
    assert list(report.json) == list(printed)
    assert _steady(report.json) == _steady(printed)


def test_replay_returns_what_the_command_prints(capsys, tmp_path):
    log = tmp_path / "run.jsonl"
    run_scenario(RunConfig("ball_in_box", quiet=True, log=log))
    report = replay(log)
    assert isinstance(report, ReplayReport) and not report.warnings
    assert main(["replay", str(log), "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == report.json
    assert main(["replay", str(log)]) == 0
    assert capsys.readouterr().out == report.text + "\n"


def test_replay_warns_of_a_log_cut_short(tmp_path):
    log = tmp_path / "run.jsonl"
    run_scenario(RunConfig("ball_in_box", quiet=True, log=log))
    lines = log.read_text().splitlines()
    cut = tmp_path / "cut.jsonl"
    cut.write_text("\n".join(lines[:10]) + "\n")
    report = replay(cut)
    assert report.warnings == [f"warning: {cut}: {report.json['reason']}"]


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"human": "lazy"}, "--human 'lazy': choose one of passive"),
        ({"reaction": "panic"}, "--reaction 'panic': choose one of"),
        ({"simulator": "physx"}, "--simulator 'physx': choose one of auto, analytic, kinematic"),
        ({"perception": "lidar"}, "--perception 'lidar': choose one of given, scene"),
        ({"seed": -1}, "--seed must be a whole number"),
        ({"realtime": 0.0}, "--realtime must be a finite number > 0"),
        ({"human_sensing": "har-real"}, "--human-sensing har-real needs --hmp DIR"),
        ({"hmp": "."}, "--hmp goes with --human-sensing har-real"),
        ({"human_sensing": "har-real", "hmp": "/no/such/dir"}, "--hmp /no/such/dir: not a dir"),
        ({"repair": True}, "--repair needs --perception scene"),
        ({"har_model": "m.npz"}, "--har-model goes with --human-sensing har"),
    ],
)
def test_a_bad_config_is_one_error_naming_the_option(fields, message):
    with pytest.raises(FlexhrcError, match=message.replace("(", r"\(").replace(")", r"\)")):
        RunConfig("ball_in_box", **fields)


@pytest.mark.parametrize(
    ("config", "message"),
    [
        (RunConfig("ball_in_box", fail=("fly:1",)), "--fail 'fly:1': unknown robot action 'fly'"),
        (RunConfig("ball_in_box", fail=("pick:0",)), "--fail 'pick:0': N must be at least 1"),
        (RunConfig("ball_in_box", human_takes=(0,)), "--human-takes 0: steps are counted from 1"),
        (
            RunConfig("ball_in_box", simulator="analytic", disturb=("slow_arm",)),
            "--disturb needs --simulator kinematic",
        ),
        (RunConfig(TableDemo(legs=2), human_takes=(3,)), "not one of the bolts 1..2"),
        (RunConfig(TableDemo(legs=30)), "--legs 30: too many"),
        (RunConfig(TableDemo(human=False), human="takeover"), "drop --no-human"),
        (RunConfig("no_such_scenario"), "unknown scenario 'no_such_scenario'"),
    ],
)
def test_a_config_the_scenario_refuses_fails_before_the_run(config, message, tmp_path):
    with pytest.raises(FlexhrcError, match=message):
        run_scenario(dataclasses.replace(config, quiet=True, log=tmp_path / "never.jsonl"))
    assert not (tmp_path / "never.jsonl").exists()


def test_a_config_is_frozen_and_has_the_commands_defaults():
    from flexhrc.cli import build_parser

    config = RunConfig()
    with pytest.raises(dataclasses.FrozenInstanceError):
        config.seed = 1  # type: ignore[misc]
    args = build_parser().parse_args(["run", "table_assembly"])
    for f in dataclasses.fields(RunConfig)[1:]:
        assert getattr(args, f.name) in (f.default, [], None), f.name
        assert f.default in ((), None) or getattr(args, f.name) == f.default, f.name
    assert Path(str(config.scenario)).name == "table_assembly"
