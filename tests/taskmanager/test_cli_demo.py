"""`flexhrc demo table`, `flexhrc run`, `flexhrc replay`: output and JSON contract."""

from __future__ import annotations

import json
import subprocess
import sys

from flexhrc.cli import main

from ..conftest import subprocess_env

KEYS = {
    "outcome",
    "reason",
    "robot_actions",
    "human_actions",
    "decisions",
    "branches_simulated",
    "timing",
    "legs_by_agent",
}
TIMING = {
    "task_manager_s",
    "task_representation_s",
    "simulator_s",
    "robot_actions_s",
    "human_actions_s",
    "total_s",
}


def test_demo_table_prints_a_live_trace_and_table_i():
    proc = subprocess.run(
        [sys.executable, "-m", "flexhrc", "demo", "table"],
        capture_output=True,
        text=True,
        env=subprocess_env(),
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout
    assert "decide robot_1 (cost 4): 8 branches simulated" in out
    assert "left   approach(" in out or "right  approach(" in out
    assert "outcome: SOLVED" in out
    for row in (
        "Task Manager",
        "Task Representation",
        "Simulator",
        "Robot actions",
        "Human actions",
        "Compute total",
        "Assembly makespan",
    ):
        assert row in out
    # compute (wall clock) and simulated time are never added into one "Total" (issue 9, item 7)
    assert not any(line.startswith("Total") for line in out.splitlines())
    assert "Traceback" not in proc.stderr


def test_demo_json_contract(capsys):
    code = main(["demo", "table", "--legs", "3", "--human", "cooperative", "--seed", "1", "--json"])
    captured = capsys.readouterr()
    data = json.loads(captured.out)
    assert code == 0
    assert set(data) >= KEYS and set(data["timing"]) >= TIMING
    assert data["outcome"] == "solved" and data["reason"] is None
    assert set(data["legs_by_agent"]) == {"human", "left", "right"}
    assert sum(data["legs_by_agent"].values()) == 3
    assert "decide robot_1" in captured.err  # the trace goes to stderr under --json


def test_failed_outcome_has_a_reason_and_exit_1(capsys):
    code = main(["demo", "table", "--no-human", "--unreachable-bolt", "2", "--json", "--quiet"])
    data = json.loads(capsys.readouterr().out)
    assert code == 1 and data["outcome"] == "failed" and data["reason"]


def test_log_replay_and_plot(tmp_path, capsys):
    log, png = tmp_path / "run.jsonl", tmp_path / "timeline.png"
    assert (
        main(
            [
                "demo",
                "table",
                "--human",
                "takeover",
                "--log",
                str(log),
                "--plot",
                str(png),
                "--json",
                "--quiet",
            ]
        )
        == 0
    )
    live = json.loads(capsys.readouterr().out)
    assert png.stat().st_size > 10_000
    assert main(["replay", str(log), "--json"]) == 0
    replayed = json.loads(capsys.readouterr().out)
    for key in (
        "outcome",
        "robot_actions",
        "human_actions",
        "decisions",
        "branches_simulated",
        "legs_by_agent",
    ):
        assert replayed[key] == live[key], key
    assert replayed["timing"] == {k: live["timing"][k] for k in TIMING}
    assert main(["replay", str(log)]) == 0
    assert "Robot actions" in capsys.readouterr().out


def test_run_scenario_file(tmp_path, capsys):
    f = tmp_path / "small.yaml"
    f.write_text(
        "scenario: table_assembly\nlegs: 2\ntabletop: small\nleg_length: short\n"
        "profile: passive\nleg_positions: [[0.35, 0.4, 0], [0.35, -0.4, 0]]\n"
    )
    assert main(["run", str(f), "--json", "--quiet"]) == 0
    assert json.loads(capsys.readouterr().out)["outcome"] == "solved"


def test_bad_inputs_are_one_line_errors(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("scenario: table_assembly\nlegz: 2\n")
    assert main(["run", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert (
        err
        == f"error: {bad}:2: unknown key 'legz' (allowed: human, leg_length, leg_positions, legs, "
        "profile, reachable_only_by, scenario, seed, tabletop, unreachable_bolts)"
    )
    assert main(["demo", "table", "--legs", "0"]) == 2
    assert "--legs must be at least 1" in capsys.readouterr().err
    assert main(["demo", "table", "--fail", "transport:x"]) == 2
    assert "--fail 'transport:x'" in capsys.readouterr().err
    broken = tmp_path / "broken.jsonl"
    broken.write_text('{"t": 0, "type": "start"}\nnot json\n')
    assert main(["replay", str(broken)]) == 2
    assert f"{broken}:2: not a JSON line" in capsys.readouterr().err
