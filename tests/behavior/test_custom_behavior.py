"""Your own behaviours: the runnable example, behaviour types in task files (Python and YAML)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from flexhrc.behavior import (
    BehaviorNetwork,
    MoveRule,
    Visit,
    behavior_types,
    check_run,
    load_task_document,
    parse_prefix,
    random_world,
)
from flexhrc.cli import main
from flexhrc.errors import FormatError
from tests.conftest import REPO, subprocess_env


def test_the_custom_behaviour_example_runs(tmp_path):
    png = tmp_path / "inspect.png"
    proc = subprocess.run(
        [sys.executable, str(REPO / "examples" / "custom_behavior.py"), "--plot", str(png)],
        env=subprocess_env(),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert "start  look_at_mug" in proc.stdout and "done   glance_at_tray" in proc.stdout
    assert "outcome: done" in proc.stdout and "constraints: respected" in proc.stdout
    assert png.read_bytes()[:4] == b"\x89PNG"


TASK = """task: {THEN: [cup, look]}
types:
  peek: {base: visit, offset: [0, 0, 0.1], dwell: 0.5}
behaviors:
  look: {type: peek, object: cup}
world:
  objects:
    cup: {position: [0.5, 0.0, 0.75], target: [0.7, 0.1, 0.75]}
"""


def test_a_yaml_declared_type_runs_from_the_command_line(tmp_path, capsys):
    f = tmp_path / "t.yaml"
    f.write_text(TASK)
    assert main(["behave", str(f)]) == 0
    out = capsys.readouterr().out
    assert "order: cup, look" in out and "constraints: respected" in out
    assert {"pick_and_place", "visit"} <= set(behavior_types())


@pytest.mark.parametrize(
    ("edit", "line", "fragment"),
    [
        (("type: peek", "type: poke"), 5, "unknown behaviour type 'poke'"),
        (("look: {type", "stare: {type"), 5, "'stare' is not a behaviour of the task"),
        (("base: visit", "base: nothing"), 3, "unknown behaviour type 'nothing'"),
        (("dwell: 0.5", "dwell: .nan"), 5, "dwell must be in 0..3600"),
        (("offset: [0, 0, 0.1]", "offset: [0, 0]"), 5, "visit offset must be a list of 3"),
        (("object: cup}", "objekt: cup}"), 5, "unknown parameter 'objekt'"),
    ],
)
def test_type_errors_name_the_file_and_line(edit, line, fragment):
    with pytest.raises(FormatError) as exc:
        load_task_document(TASK.replace(*edit), "t.yaml")
    assert f"t.yaml:{line}:" in str(exc.value) and fragment in str(exc.value)


def test_a_visit_is_reset_when_its_object_moves_during_the_dwell():
    doc = load_task_document(TASK.replace("dwell: 0.5", "dwell: 3.0"), "t.yaml")
    assert doc.world is not None
    world = doc.world
    net = BehaviorNetwork(doc.task, world, behaviors=doc.behaviors)
    assert isinstance(net.node("look"), Visit)
    while not any(e.kind == "start" and e.source == "look" for e in net.log):
        net.tick()
    world.moves.append(MoveRule("cup", (0.6, -0.2, 0.75), at=net.clock.now() + 1.0))
    world._fired.append(False)
    result = net.run()
    assert result.outcome == "done" and check_run(doc.task, result.runs) == []
    assert [r.outcome for r in result.runs if r.behavior == "look"] == ["reset", "done"]


def test_factories_replace_pick_and_place_through_the_api():
    task = parse_prefix("(AND a b)")
    made = []

    def factory(name, world, transport, params):
        made.append(name)
        return Visit(name, world, transport, params, pose=(0.4, 0.0, 1.0), dwell=0.2)

    net = BehaviorNetwork(task, random_world(["a"], seed=1), behaviors={"b": factory})
    result = net.run()
    assert made == ["b"] and result.outcome == "done" and sorted(result.order) == ["a", "b"]


def test_a_python_type_from_the_command_line_with_types(capsys, tmp_path):
    example = REPO / "examples" / "custom_behavior.py"
    namespace: dict = {}
    exec(compile(example.read_text(), str(example), "exec"), namespace)
    task = tmp_path / "inspect.yaml"
    task.write_text(namespace["TASK_FILE"])
    assert main(["behave", str(task), "--types", str(example), "--json"]) == 0
    data = __import__("json").loads(capsys.readouterr().out)
    assert data["outcome"] == "done" and "look_at_mug" in data["order"]
    assert main(["behave", str(task), "--types", "no_such_module_xyz"]) == 2
    assert "--types no_such_module_xyz: ModuleNotFoundError" in capsys.readouterr().err
