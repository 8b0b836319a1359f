"""One task, two executors: the table-setting task compiled to an AND/OR graph runs through the
Task Manager with an operator (`flexhrc run` on examples/compiled_task)."""

from __future__ import annotations

import json

import pytest

from flexhrc.behavior.compile import compile_task
from flexhrc.cli import main
from flexhrc.representation.formats.yaml_format import dump_yaml
from flexhrc.representation.hierarchy import split_qualified
from flexhrc.scenario.builtin.table_setting import table_setting_task
from tests.behavior.test_compile import satisfies
from tests.conftest import REPO

EXAMPLE = REPO / "examples" / "compiled_task"


def test_the_shipped_graph_is_what_behave_compile_writes():
    graph = (EXAMPLE / "table_setting.graph.yaml").read_text()
    assert graph == dump_yaml(compile_task(table_setting_task()))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_task_manager_runs_the_compiled_task_with_a_human(capsys, seed):
    scenario = EXAMPLE / "table_setting.scenario.yaml"
    code = main(["run", str(scenario), "--json", "--seed", str(seed)])
    out = capsys.readouterr().out
    assert code == 0
    data = json.loads(out[: out.rindex("}") + 1])
    assert data["outcome"] == "solved"
    assert data["by_agent"]["human"] > 0 and data["by_agent"]["arm"] > 0  # they cooperated
    solved = sorted(data["solved_hyperarcs"], key=lambda s: s["t"])
    order = [split_qualified(s["hyperarc"])[1] for s in solved]
    behaviours = [b for b in order if "@" not in b]
    assert satisfies(table_setting_task(), behaviours), behaviours
