"""`flexhrc scenario generate`: random tasks that validate and run, determined by their seed."""

from __future__ import annotations

import pytest
import yaml

from flexhrc import scenario
from flexhrc.app import RunConfig, run_scenario
from flexhrc.cli import main
from flexhrc.errors import FlexhrcError
from flexhrc.scenario.generate import GenerateSpec, generate, generate_document, write_generated

SIZES = [(1, 2, 1), (2, 2, 2), (5, 3, 2), (8, 4, 3), (12, 5, 4), (16, 6, 6), (24, 8, 5)]


def _errors(path):
    return [str(f) for f in scenario.validate(path) if f.severity == "error"]


@pytest.mark.parametrize(("actions", "agents", "width"), SIZES)
@pytest.mark.parametrize("seed", [0, 1, 7])
def test_generated_tasks_validate_and_run_to_the_goal(tmp_path, actions, agents, width, seed):
    path = write_generated(
        tmp_path / "task.yaml", actions=actions, agents=agents, width=width, seed=seed
    )
    assert scenario.validate(path) == []  # no error, no warning
    for profile in ("passive", "cooperative"):
        report = run_scenario(RunConfig(path, human=profile, seed=seed, quiet=True))
        assert report.result.outcome == "solved", report.json["reason"]
        # every cooperation path has exactly `actions` actions
        assert report.json["robot_actions"] + report.json["human_actions"] >= actions
        assert len(report.json["solved_hyperarcs"]) == actions


@pytest.mark.parametrize("profile", ["takeover", "random", "reluctant"])
def test_one_person_tasks_run_to_the_goal_with_deviating_operators(tmp_path, profile):
    for seed in range(3):
        path = write_generated(
            tmp_path / f"t{seed}.yaml", actions=10, agents=4, width=3, seed=seed, force=True
        )
        report = run_scenario(RunConfig(path, human=profile, seed=seed, quiet=True))
        assert report.result.outcome == "solved", report.json["reason"]


def test_fifty_actions_twenty_agents_validate_and_run(tmp_path):
    path = write_generated(tmp_path / "big.yaml", actions=50, agents=20, width=8, seed=3)
    assert _errors(path) == []
    sc = scenario.load(path)
    arms = [a for a in sc.domain.agents.values() if not a.is_human]
    assert (len(arms), len(sc.humans)) == (15, 5)
    report = run_scenario(RunConfig(path, seed=3, quiet=True))
    assert report.result.outcome == "solved", report.json["reason"]
    assert len(report.json["solved_hyperarcs"]) == 50


def test_the_same_arguments_give_the_same_text_and_another_seed_another():
    a = generate(actions=12, agents=5, width=3, seed=4)
    assert a == generate(actions=12, agents=5, width=3, seed=4)
    assert a != generate(actions=12, agents=5, width=3, seed=5)
    assert "&id" not in a and "*id" not in a  # no YAML aliases in a file meant to be read
    assert yaml.safe_load(a) == generate_document(actions=12, agents=5, width=3, seed=4)


@pytest.mark.parametrize("seed", range(5))
def test_a_task_has_alternatives_joint_robot_only_person_only_steps_and_reachability(seed):
    doc = generate_document(actions=20, agents=6, width=4, seed=seed)
    (graph,) = doc["graphs"].values()
    into: dict[str, list[dict]] = {}
    for h in graph["hyperarcs"]:
        into.setdefault(h["parent"], []).append(h)
    assert len(into) == 20  # one node per step, each reached by its alternatives
    assert all(len(h["actions"]) == 1 for h in graph["hyperarcs"])
    kinds = [sorted(h["name"].rsplit("_", 1)[1] for h in hs) for hs in into.values()]
    assert any(len(k) > 1 for k in kinds)  # OR: an arm's or a person's
    assert any("joint" in k for k in kinds)
    assert ["arm"] in kinds and ["person"] in kinds  # robot-only, person-only
    for hs in into.values():  # alternatives share their children (the same AND)
        assert len({tuple(h["children"]) for h in hs}) == 1
    actions = doc["domain"]["actions"]
    assert any("joint" in a["agents"] for a in actions.values())
    arms = [n for n, a in doc["domain"]["agents"].items() if a["kind"] == "robot"]
    reach = [o["reachable_by"] for o in doc["world"]["objects"].values()]
    assert all(set(r) < set(arms) for r in reach)  # no part every arm reaches
    # the most steps at once is the width: a layer of the tree
    assert "up to 4 at once" in doc["description"]


def test_width_one_is_a_chain_and_width_n_a_star():
    chain = generate_document(actions=6, agents=3, width=1, seed=0)
    (g,) = chain["graphs"].values()
    assert all(len(h["children"]) == 1 for h in g["hyperarcs"])
    assert sum(n["name"].endswith("_ready") for n in g["nodes"]) == 1
    star = generate_document(actions=7, agents=3, width=7, seed=0)
    (g,) = star["graphs"].values()
    assert "3 layers" in star["description"]  # 1, 2, 4: at most twice the layer above


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        (dict(actions=0, agents=3, width=1), "--actions must be a whole number in 1..1000"),
        (dict(actions=5, agents=1, width=1), "--agents must be a whole number in 2..64"),
        (dict(actions=5, agents=3, width=6), "--width must be a whole number in 1..5"),
        (dict(actions=5, agents=3, width=0), "--width must be a whole number in 1..5"),
        (dict(actions=5, agents=3, width=2, seed=-1), "--seed must be a whole number"),
        (dict(actions=5, agents=3, width=2, persons=3), "--persons must be a whole number in 1..2"),
        (dict(actions=True, agents=3, width=1), "--actions must be a whole number"),
    ],
)
def test_bad_arguments_are_one_error_naming_the_option(kwargs, words):
    with pytest.raises(FlexhrcError, match=words.replace(".", r"\.")):
        GenerateSpec(**kwargs)
    with pytest.raises(FlexhrcError):
        generate(**kwargs)


def test_cli_writes_a_file_and_refuses_to_overwrite_it_without_force(tmp_path, capsys):
    out = tmp_path / "g.yaml"
    argv = ["scenario", "generate", "--actions", "6", "--agents", "3", "--width", "2"]
    assert main([*argv, "--seed", "2", "-o", str(out)]) == 0
    first = out.read_text()
    assert first == generate(actions=6, agents=3, width=2, seed=2)
    assert main([*argv, "--seed", "3", "-o", str(out)]) == 2
    assert "already exists (use --force" in capsys.readouterr().err
    assert out.read_text() == first  # untouched
    assert main([*argv, "--seed", "3", "-o", str(out), "--force"]) == 0
    assert out.read_text() == generate(actions=6, agents=3, width=2, seed=3)
    assert main(["scenario", "validate", str(out)]) == 0


def test_cli_prints_the_yaml_without_output(capsys):
    argv = ["scenario", "generate", "--actions", "4", "--agents", "2", "--width", "2"]
    assert main(argv) == 0
    assert capsys.readouterr().out == generate(actions=4, agents=2, width=2, seed=0)


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--actions", "4", "--agents", "3", "--width", "9"], "error: --width must be"),
        (["--actions", "-1", "--agents", "3", "--width", "1"], "error: --actions must be"),
        (["--actions", "x", "--agents", "3", "--width", "1"], "argument --actions"),
        (["--actions", "4", "--agents", "3", "--width", "1", "--force"], "--force goes with -o"),
        (["--actions", "4", "--agents", "3"], "--width"),
    ],
)
def test_cli_bad_arguments_exit_2_with_one_line(capsys, extra, words):
    assert main(["scenario", "generate", *extra]) == 2
    err = capsys.readouterr().err
    assert words in err
    assert len(err.strip().splitlines()) == 1


def test_cli_checks_the_output_path_before_the_work(tmp_path, capsys, monkeypatch):
    import flexhrc.scenario.generate as gen

    def boom(*args, **kwargs):  # the work must not start
        raise AssertionError("generated before the output was checked")

    monkeypatch.setattr(gen, "generate", boom)
    argv = ["scenario", "generate", "--actions", "4", "--agents", "3", "--width", "1", "-o"]
    assert main([*argv, str(tmp_path / "missing" / "g.yaml")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main([*argv, str(tmp_path / "g.txt")]) == 2
    assert "unsupported output format" in capsys.readouterr().err
    (tmp_path / "dir.yaml").mkdir()
    assert main([*argv, str(tmp_path / "dir.yaml")]) == 2
    assert "is a folder" in capsys.readouterr().err


@pytest.mark.parametrize("profile", ["takeover", "random"])
def test_several_people_who_take_steps_run_to_the_goal(tmp_path, profile):
    """A takeover operator's step goes to that operator: eq. 21 over every person used to hand
    it to another one, busy with a request of their own, and the run deadlocked (seed 5)."""
    solved = 0
    for seed in range(3, 8):
        path = write_generated(
            tmp_path / f"t{seed}.yaml", actions=20, agents=8, width=5, seed=seed, force=True
        )
        report = run_scenario(RunConfig(path, human=profile, seed=seed, quiet=True))
        assert report.result.outcome == "solved", (seed, report.json["reason"])
        people = {a for a, n in report.json["by_agent"].items() if a.startswith("op") and n}
        solved += len(people) > 1
    assert solved  # the people shared the work in some run, so the case was exercised
