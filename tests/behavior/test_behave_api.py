"""``flexhrc behave`` as library calls (issue 19, "a thin CLI"): a config in, a report out.

The report of each function is what the command prints: its ``data`` is the ``--json`` document,
its ``text()`` the text, its ``exit_code`` the exit code. Configs check their values when they
are made, with the messages the command prints."""

from __future__ import annotations

import json
from dataclasses import FrozenInstanceError

import pytest

from flexhrc.behavior.behave import (
    CompileConfig,
    RenderConfig,
    ReplayConfig,
    compile_to_file,
    render,
    replay,
    run_behave,
)
from flexhrc.behavior.command import BehaveConfig, LoadedTask, load_target
from flexhrc.cli import main
from flexhrc.errors import FlexhrcError
from flexhrc.scenario.builtin.table_setting import load_scenario


def cli(capsys, *argv):
    code = main(["behave", *argv])
    out, _err = capsys.readouterr()
    return code, out


def cli_json(capsys, *argv):
    code, out = cli(capsys, *argv, "--json")
    return code, json.loads(out)


def same(report):
    """The report's document as the command prints it (through JSON)."""
    return json.loads(json.dumps(report.data))


@pytest.mark.parametrize(
    ("argv", "config"),
    [
        (["(THEN a (AND b c))", "--seed", "5"], BehaveConfig("(THEN a (AND b c))", seed=5)),
        (
            ["(OR a b)", "--arms", "2", "--max-ticks", "40"],
            BehaveConfig("(OR a b)", arms=2, max_ticks=40),
        ),
        (["(THEN a b)", "--render", "dot"], BehaveConfig("(THEN a b)", render="dot")),
        (["(AND a b c)", "--robots", "2"], BehaveConfig("(AND a b c)", robots=2)),
    ],
    ids=["run", "two-arms-timeout", "render", "team"],
)
def test_run_behave_report_is_the_command_output(capsys, argv, config):
    report = run_behave(config)
    code, data = cli_json(capsys, *argv)
    assert same(report) == data and report.exit_code == code
    code, text = cli(capsys, *argv)
    assert report.text().rstrip("\n") + "\n" == text  # as emit prints it


def test_a_named_scenario_is_a_loaded_task(capsys):
    sc = load_scenario("table-setting", layout=2)
    task = LoadedTask("table-setting (layout 2)", sc.task, sc.world)
    report = run_behave(BehaveConfig(task))
    code, data = cli_json(capsys, "table-setting", "--layout", "2")
    assert same(report) == data and code == report.exit_code == 0


def test_replay_render_and_compile_reports(capsys, tmp_path):
    log = tmp_path / "run.jsonl"
    live = run_behave(BehaveConfig("(THEN a (AND b c))", log=str(log)))
    assert live.data["log"] == str(log)
    report = replay(ReplayConfig(str(log)))
    assert same(report) == cli_json(capsys, "replay", str(log))[1]
    assert [report.data[k] for k in ("order", "runs")] == [live.data[k] for k in ("order", "runs")]

    dot = tmp_path / "net.dot"
    report = render(RenderConfig("(THEN a (AND b c))", str(dot), log=str(log), at=1.0))
    text = dot.read_text()
    assert report.data == {"output": str(dot), "task": "(THEN a (AND b c))", "at": 1.0}
    assert cli_json(
        capsys, "render", "(THEN a (AND b c))", "-o", str(dot), "--log", str(log), "--at", "1"
    )[1] == same(report)
    assert dot.read_text() == text

    graph = tmp_path / "g.yaml"
    report = compile_to_file(CompileConfig("(THEN a (OR b c))", str(graph)))
    assert report.text().startswith(f"wrote {graph}: ")
    assert same(report) == cli_json(capsys, "compile", "(THEN a (OR b c))", "-o", str(graph))[1]


def test_load_target_reads_inline_tasks_and_files(tmp_path):
    inline = load_target("(THEN a b)", arms=2, seed=1)
    assert inline.label == "inline task" and inline.world.arm_names == ["left", "right"]
    path = tmp_path / "t.txt"
    path.write_text("(AND x y)\n")
    loaded = load_target(str(path))
    assert loaded.label == str(path) and loaded.task.behaviors == ["x", "y"]
    assert load_target(loaded) is loaded
    with pytest.raises(FlexhrcError, match="no task file 'table-settin'"):
        load_target("table-settin")


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: BehaveConfig(""), "TASK_OR_SCENARIO is empty"),
        (lambda: BehaveConfig("(THEN a b)", seed=-1), "--seed must be an integer in 0..2**63-1"),
        (lambda: BehaveConfig("(THEN a b)", max_ticks=0), "--max-ticks must be in 1.."),
        (lambda: BehaveConfig("(THEN a b)", realtime=float("nan")), "--realtime SPEED must be"),
        (lambda: BehaveConfig("(THEN a b)", arms=3), "--arms must be 1 or 2"),
        (lambda: BehaveConfig("(THEN a b)", render="svg"), "--render must be ascii or dot"),
        (lambda: BehaveConfig("(THEN a b)", robots=5), "--robots must be in 1..4"),
        (lambda: BehaveConfig("(THEN a b)", transport="zenoh"), "--transport needs --robots 2"),
        (lambda: BehaveConfig("(THEN a b)", robots=2, transport="mqtt"), "--transport must be"),
        (lambda: BehaveConfig("(THEN a b)", robot="robot1"), "--robot and --peer-port are for"),
        (
            lambda: BehaveConfig("(THEN a b)", robots=2, transport="zenoh", robot="robot1"),
            "--robot needs --peer-port",
        ),
        (
            lambda: BehaveConfig("(A)", robots=2, transport="zenoh", robot="r", peer_port=-1),
            "--peer-port must be in 0..65535",
        ),
        (  # only the listener takes a port the system picks; the others need the port it got
            lambda: BehaveConfig("(A)", robots=2, transport="zenoh", robot="robot2", peer_port=0),
            "--peer-port 0 is for robot1",
        ),
        (
            lambda: BehaveConfig("(A)", robots=2, transport="zenoh", ready_file="r.json"),
            "--ready-file is for --robot",
        ),
        (
            lambda: BehaveConfig("(THEN a b)", robots=2, arms=2),
            "--arms does not apply with --robots",
        ),
        (
            lambda: BehaveConfig("(THEN a b)", render="ascii", log="x.jsonl"),
            "--log does not apply with --render",
        ),
        (lambda: ReplayConfig(""), "TASK_OR_SCENARIO is empty"),
        (lambda: RenderConfig("(THEN a b)", "x.svg", at=3.0), "--at needs --log"),
        (lambda: RenderConfig("(THEN a b)", "x.svg", log="l", at=-1.0), "--at must be a finite"),
        (lambda: CompileConfig("(THEN a b)", "g.yaml", seed=2**63), "--seed must be an integer"),
    ],
)
def test_configs_refuse_bad_values_naming_the_option(make, message):
    with pytest.raises(FlexhrcError) as info:
        make()
    assert message in str(info.value)


def test_configs_are_frozen_and_default_like_the_command():
    config = BehaveConfig("(THEN a b)")
    assert (config.seed, config.robots, config.arms, config.max_ticks, config.team) == (
        0,
        1,
        None,
        None,
        False,
    )
    with pytest.raises(FrozenInstanceError):
        config.seed = 3  # type: ignore[misc]


def test_output_paths_are_checked_before_the_run(tmp_path):
    with pytest.raises(FlexhrcError, match=r"--log /nonexistent3/x\.jsonl"):
        run_behave(BehaveConfig("(THEN a b)", log="/nonexistent3/x.jsonl"))
    with pytest.raises(FlexhrcError, match="-o "):
        compile_to_file(CompileConfig("(THEN a b)", str(tmp_path / "g.txt")))


def test_a_team_over_zenoh_needs_the_task_as_text():
    sc = load_scenario("abstract")
    task = LoadedTask("abstract", sc.task, sc.world)
    with pytest.raises(FlexhrcError, match="each robot process loads the task itself"):
        run_behave(BehaveConfig(task, robots=2, transport="zenoh"))


def test_live_lines_go_to_on_line():
    lines: list[str] = []
    report = run_behave(BehaveConfig("(THEN a b)", realtime=1000.0), on_line=lines.append)
    assert lines[0] == "inline task: (THEN a b) (real time x1000)"
    assert any("start  a" in line for line in lines)
    assert "trace:" not in report.text()
