"""`flexhrc scenario list|new|validate` and `flexhrc run FILE|NAME`: output and contracts."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from flexhrc import scenario
from flexhrc.cli import main
from flexhrc.errors import FlexhrcError
from flexhrc.scenario.starter import STARTER, write_starter

from ..conftest import subprocess_env


def test_list_names_every_shipped_scenario_one_line_each(capsys):
    assert main(["scenario", "list"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert [line.split()[0] for line in lines] == list(scenario.SHIPPED)


def test_new_writes_a_starter_that_validates_and_runs(tmp_path):
    target = tmp_path / "mine"
    env = subprocess_env()

    def flexhrc(*argv):
        return subprocess.run(
            [sys.executable, "-m", "flexhrc", *argv],
            capture_output=True,
            text=True,
            env=env,
            timeout=120,
        )

    made = flexhrc("scenario", "new", str(target))
    assert made.returncode == 0, made.stderr
    path = target / "scenario.yaml"
    assert path.read_text().startswith("# A flexhrc scenario")
    checked = flexhrc("scenario", "validate", str(path))
    assert checked.returncode == 0 and checked.stdout.startswith(f"{path}: valid: my_task")
    ran = flexhrc("run", str(path), "--json", "--quiet", "--human", "cooperative")
    assert ran.returncode == 0, ran.stderr
    data = json.loads(ran.stdout)
    assert data["outcome"] == "solved" and [x["hyperarc"] for x in data["solved_hyperarcs"]] == [
        "place_bracket",
        "place_screw",
        "tighten",
    ]
    again = flexhrc("scenario", "new", str(target))
    assert again.returncode == 2 and "already exists (use --force" in again.stderr
    assert "Traceback" not in again.stderr


def test_run_prints_a_trace_and_table_i(capsys):
    assert main(["run", "ball_in_box", "--human", "takeover"]) == 0
    out = capsys.readouterr().out
    assert "decide h1" in out and "human did pick(human, " in out
    assert "ball_in_box: outcome solved; hyper-arcs solved by human: 3" in out


def test_run_unknown_name_and_bad_reaction_are_one_line_errors(capsys):
    assert main(["run", "no_such_task"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        "error: unknown scenario 'no_such_task'; shipped: table_assembly, ball_in_box, "
        "kitchen_drawer, table_two_arms (or give a .yaml file)"
    )


def test_demo_table_is_the_shipped_table_scenario(capsys):
    assert main(["demo", "table", "--json", "--quiet", "--simulator", "analytic"]) == 0
    demo = json.loads(capsys.readouterr().out)
    assert main(["run", "table_assembly", "--json", "--quiet"]) == 0
    run = json.loads(capsys.readouterr().out)
    arcs = [x["hyperarc"] for x in demo["solved_hyperarcs"]]
    assert arcs[0] == "place_tabletop" and arcs[-1] == "check_connections"
    assert arcs == [x["hyperarc"] for x in run["solved_hyperarcs"]]
    assert demo["by_agent"] == run["by_agent"]


def test_demo_table_segments_legs_is_figs_9_to_12_alone(capsys):
    assert main(["demo", "table", "--segments", "legs", "--json", "--quiet",
                 "--simulator", "analytic"]) == 0  # fmt: skip
    data = json.loads(capsys.readouterr().out)
    assert [x["hyperarc"] for x in data["solved_hyperarcs"]] == [f"robot_{k}" for k in range(1, 5)]


def test_reaction_paper_on_the_command_line(capsys):
    assert main(["run", "table_assembly", "--human", "takeover", "--reaction", "paper",
                 "--json", "--quiet"]) == 0  # fmt: skip
    assert json.loads(capsys.readouterr().out)["outcome"] == "solved"


def test_the_tutorial_scenario_validates_and_runs_for_every_profile(capsys):
    from ..conftest import REPO

    path = REPO / "examples" / "scenarios" / "lid_task.yaml"
    assert main(["scenario", "validate", str(path)]) == 0
    capsys.readouterr()
    for profile in ("passive", "takeover", "cooperative", "random"):
        assert main(["run", str(path), "--human", profile, "--json", "--quiet"]) == 0
        assert json.loads(capsys.readouterr().out)["outcome"] == "solved"


def test_validate_and_list_speak_json(tmp_path, capsys):
    from .helpers import base, write

    doc = base()
    doc["world"]["objects"]["a"]["position"] = [0.4, 0.2]
    path = write(tmp_path, doc)
    assert main(["scenario", "validate", str(path), "--json"]) == 2
    data = json.loads(capsys.readouterr().out)
    assert data["valid"] is False and data["summary"] is None
    assert [f["severity"] for f in data["faults"]] == ["error"]
    assert data["faults"][0]["message"].startswith("object 'a': malformed pose")
    assert main(["scenario", "list", "--json"]) == 0
    assert [x["name"] for x in json.loads(capsys.readouterr().out)] == list(scenario.SHIPPED)


def test_validation_and_write_starter_are_what_the_commands_do(tmp_path, capsys):
    from .helpers import base, write

    bad = base()
    bad["world"]["objects"]["a"]["position"] = [0.4, 0.2]
    for path in (write(tmp_path, bad), "ball_in_box"):
        report = scenario.validation(path)
        code = main(["scenario", "validate", str(path), "--json"])
        assert report == json.loads(capsys.readouterr().out)
        assert code == (0 if report["valid"] else 2)
    assert report["valid"] and report["summary"] and report["file"].endswith("ball_in_box.yaml")
    target = write_starter(tmp_path / "new")
    assert target.read_text() == STARTER and scenario.validation(target)["valid"]
    with pytest.raises(FlexhrcError, match="already exists"):
        write_starter(tmp_path / "new")
    assert write_starter(tmp_path / "new", force=True) == target


def test_replay_of_a_scenario_log_gives_the_same_summary(tmp_path, capsys):
    log = tmp_path / "run.jsonl"
    args = ["run", "kitchen_drawer", "--human", "cooperative", "--seed", "2", "--json", "--quiet"]
    assert main([*args, "--log", str(log)]) == 0
    live = json.loads(capsys.readouterr().out)
    assert main(["replay", str(log), "--json"]) == 0
    replayed = json.loads(capsys.readouterr().out)
    for key in ("outcome", "robot_actions", "human_actions", "decisions", "branches_simulated",
                "fixed_by_agent", "solved_hyperarcs", "by_agent"):  # fmt: skip
        assert replayed[key] == live[key], key
