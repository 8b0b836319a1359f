"""`flexhrc behave` on bad input and faults (issue 9, the behave cases of the bad-input probe),
streamed logs, replay and render."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from flexhrc.cli import main
from tests.conftest import subprocess_env


def run_cli(capsys, *argv):
    code = main(["behave", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_error(capsys, argv, fragment):
    code, out, err = run_cli(capsys, *argv)
    assert code == 2, (argv, out, err)
    assert out == ""
    assert err.startswith("error: ") and err.count("\n") == 1 and "Traceback" not in err
    assert fragment in err, err
    return err


@pytest.mark.parametrize(
    ("argv", "fragment"),
    [
        # the behave cases of the bad-input probe (../shared/reviews/bad-input-probe-2026-12-01.md)
        pytest.param(["(OR a b)", "--seed", "-5"], "--seed", id="B11-seed"),
        pytest.param(["table-setting", "--layout", "0"], "--layout 0", id="C10-layout-0"),
        pytest.param(["(THEN a b)", "--max-ticks", "-5"], "--max-ticks", id="C11-max-ticks"),
        (["(THEN a b)", "--max-ticks", "0"], "--max-ticks"),
        pytest.param([""], "TASK_OR_SCENARIO is empty", id="D-empty-target"),
        (["(THEN a b)", "--realtime", "nan"], "--realtime"),
        (["(THEN a b)", "--realtime", "-1"], "--realtime"),
        # B8, B9: output paths checked before the run, the plot extension first
        pytest.param(
            ["(THEN a b)", "--log", "/nonexistent3/x.jsonl"],
            "--log /nonexistent3/x.jsonl",
            id="B8-log",
        ),
        pytest.param(["(THEN a b)", "--log", "/dev/full"], "--log /dev/full", id="B8-dev-full"),
        pytest.param(
            ["(THEN a b)", "--plot", "/nonexistent2/x.png"],
            "--plot /nonexistent2/x.png",
            id="B8-plot",
        ),
        pytest.param(["(THEN a b)", "--plot", "x.xyz"], "unsupported output format", id="B9"),
        (["(THEN a b)", "--log", "/tmp"], "is a folder"),
        # options without their companion
        (["(THEN a b)", "--at", "3"], "--at only applies"),
        (["(THEN a b)", "-o", "x.svg"], "-o only applies"),
        (["replay"], "needs a LOG"),
        (["render", "(THEN a b)"], "needs -o OUT"),
        (["(THEN a b)", "extra"], "unexpected argument 'extra'"),
        (["(THEN a b)", "--render", "ascii", "--log", "x.jsonl"], "does not apply with --render"),
        (["render", "(THEN a b)", "-o", "x.svg", "--realtime", "2"], "--realtime does not apply"),
    ],
)
def test_bad_arguments_are_one_error_line(capsys, argv, fragment):
    one_error(capsys, argv, fragment)


def test_plot_into_an_input_is_refused(capsys, tmp_path):
    task = tmp_path / "t.txt"
    task.write_text("(THEN a b)\n")
    one_error(capsys, [str(task), "--log", str(task)], "is an input of this command")
    assert task.read_text() == "(THEN a b)\n"


def test_no_folder_is_created_for_a_bad_plot_path(capsys, tmp_path):
    target = tmp_path / "missing" / "g.png"
    one_error(capsys, ["(THEN a b)", "--plot", str(target)], "does not exist")
    assert not target.parent.exists()


@pytest.mark.parametrize("depth", [500, 10_000], ids=["B6-500", "B6-10000"])
def test_deep_nesting_is_a_clear_error_not_a_recursion_error(capsys, tmp_path, depth):
    deep = tmp_path / "deep.txt"
    deep.write_text("(THEN a" * depth + " z" + ")" * depth + "\n")
    one_error(capsys, [str(deep)], "nested more than 200 levels deep")
    yml = tmp_path / "deep.yaml"
    yml.write_text("task: " + "{THEN: [" * depth + "z" + "]}" * depth + "\n")
    one_error(capsys, [str(yml)], "deep")


def test_nesting_up_to_the_limit_runs_renders_and_compiles(capsys, tmp_path):
    from flexhrc.behavior import BehaviorNetwork, check_run, parse_prefix, random_world
    from flexhrc.behavior.task import MAX_DEPTH

    names = [f"n{i}" for i in range(MAX_DEPTH)]
    text = "".join(f"(THEN {n} " for n in names) + "z" + ")" * MAX_DEPTH
    task = parse_prefix(text)
    world = random_world(task.behaviors, seed=0)
    for arm in world.arms.values():
        arm.speed = 5.0  # a fast arm: the same logic in fewer ticks
    world.grasp_time = world.place_time = 0.1
    result = BehaviorNetwork(task, world).run()
    assert result.order == [*names, "z"] and check_run(task, result.runs) == []
    code, out, _ = run_cli(capsys, text, "--render", "ascii")
    assert code == 0 and out.count("THEN (THEN_") == MAX_DEPTH
    graph = tmp_path / "deep.yaml"
    assert run_cli(capsys, "compile", text, "-o", str(graph))[0] == 0


def test_log_is_streamed_and_replay_reproduces_the_live_summary(capsys, tmp_path):
    log = tmp_path / "run.jsonl"
    png = tmp_path / "g.png"
    code, live, _ = run_cli(capsys, "table-setting-robustness", "--log", str(log))
    assert code == 0
    lines = [json.loads(line) for line in log.read_text().splitlines()]
    assert lines[0]["type"] == "behave_start" and lines[-1]["type"] == "behave_end"
    assert all(rec["type"] == "event" for rec in lines[1:-1])
    code, replayed, _ = run_cli(capsys, "replay", str(log), "--plot", str(png))
    assert code == 0
    summary = live.split("\n\n")[-1].splitlines()
    summary = [s for s in summary if not s.startswith("event log:")]
    got = [s for s in replayed.split("\n\n")[-1].splitlines() if not s.startswith("gantt")]
    assert got == summary
    assert "resets: 2" in replayed
    assert png.read_bytes()[:4] == b"\x89PNG"
    code, live_json, _ = run_cli(capsys, "table-setting-robustness", "--json")
    code, replay_json, _ = run_cli(capsys, "replay", str(log), "--json")
    a, b = json.loads(live_json), json.loads(replay_json)
    for key in ("outcome", "order", "ticks", "resets", "time", "runs", "violations"):
        assert a[key] == b[key], key


def test_replay_names_the_bad_line(capsys, tmp_path):
    log = tmp_path / "run.jsonl"
    assert run_cli(capsys, "(THEN a b)", "--log", str(log))[0] == 0
    lines = log.read_text().splitlines()
    bad = json.loads(lines[3])
    bad["t"] = "abc"
    lines[3] = json.dumps(bad)
    broken = tmp_path / "broken.jsonl"
    broken.write_text("\n".join(lines) + "\n")
    one_error(capsys, ["replay", str(broken)], f"{broken}:4: 't' must be a number")
    end = json.loads(lines[-1])
    end["outcome"] = "exploded"
    lines = [*log.read_text().splitlines()[:-1], json.dumps(end)]
    broken.write_text("\n".join(lines) + "\n")
    one_error(capsys, ["replay", str(broken)], "unknown outcome 'exploded'")
    foreign = tmp_path / "foreign.jsonl"
    foreign.write_text('{"t": 0, "type": "start"}\n')
    one_error(capsys, ["replay", str(foreign)], "not a behaviour log")


def test_render_with_states_from_the_log(capsys, tmp_path):
    log = tmp_path / "run.jsonl"
    assert run_cli(capsys, "table-setting", "--log", str(log))[0] == 0
    dot = tmp_path / "net.dot"
    code, _, _ = run_cli(
        capsys, "render", "table-setting", "-o", str(dot), "--log", str(log), "--at", "20"
    )
    assert code == 0
    text = dot.read_text()
    assert "cluster_legend" in text and "at 20.0 s" in text
    assert '"placemat" [shape=ellipse, label="placemat", style=filled, fillcolor="#3c78d8"]' in text
    if shutil.which("dot"):  # graphviz (scripts/setup.sh installs it)
        svg = tmp_path / "net.svg"
        assert run_cli(capsys, "render", "table-setting", "-o", str(svg))[0] == 0
        assert svg.read_text().lstrip().startswith("<?xml")
    one_error(
        capsys,
        ["render", "(THEN a b)", "-o", str(dot), "--log", str(log)],
        "the log is of another task",
    )


def test_realtime_prints_state_changes_as_they_happen(capsys):
    code, out, _ = run_cli(capsys, "(THEN a b)", "--realtime", "1000")
    assert code == 0
    assert "real time x1000" in out and "state  a" in out and "start  a" in out
    assert "trace:" not in out  # printed live, not again at the end


def _cli(*argv):
    return [sys.executable, "-m", "flexhrc", "behave", *argv]


def _wait_for_events(path: Path, n: int, proc, timeout=30.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if path.exists() and len(path.read_text().splitlines()) >= n:
            return
        if proc.poll() is not None:
            raise AssertionError(proc.stderr.read())
        time.sleep(0.05)
    raise AssertionError("no events written")


@pytest.mark.slow
def test_sigkill_leaves_a_readable_log_and_replay_says_cut_short(tmp_path):
    log = tmp_path / "run.jsonl"
    proc = subprocess.Popen(
        _cli("table-setting", "--log", str(log), "--realtime", "20"),
        env=subprocess_env(),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        _wait_for_events(log, 6, proc)
        # a second run on the same log is refused while the first holds it
        second = subprocess.run(
            _cli("(THEN a b)", "--log", str(log)),
            env=subprocess_env(),
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert second.returncode == 2 and "in use by another flexhrc run" in second.stderr
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
    written = len(log.read_text().splitlines())
    replay = subprocess.run(
        _cli("replay", str(log), "--json"),
        env=subprocess_env(),
        capture_output=True,
        text=True,
        timeout=60,
    )
    data = json.loads(replay.stdout)
    assert data["cut_short"] is True and data["outcome"] == "cut short"
    assert data["events"] == written - 1  # every line but the header


@pytest.mark.slow
def test_sigterm_writes_the_last_line(tmp_path):
    log = tmp_path / "run.jsonl"
    proc = subprocess.Popen(
        _cli("table-setting", "--log", str(log), "--realtime", "20"),
        env=subprocess_env(),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        _wait_for_events(log, 6, proc)
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=20) == 130
    finally:
        if proc.poll() is None:
            proc.kill()
    last = json.loads(log.read_text().splitlines()[-1])
    assert last["type"] == "behave_end" and last["outcome"] == "interrupted"
