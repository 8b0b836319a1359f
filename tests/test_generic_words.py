"""No table word in what flexhrc prints about a task that is not the table (issue 19, item 5).

Summaries, JSON and logs speak of hyper-arcs, actions and agents. The table assembly keeps its
own words (``legs_by_agent``, "legs connected by ..."), and its variant ``table_two_arms`` names
its objects legs and bolts; every other scenario — shipped, example,
the starter of ``flexhrc scenario new`` — must not show ``leg``, ``bolt`` or ``tabletop`` in the
text or the JSON of ``flexhrc run``, ``flexhrc replay`` or ``flexhrc cell``.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from flexhrc import scenario
from flexhrc.cli import main

from .conftest import REPO

TABLE_WORDS = re.compile(r"leg|bolt|tabletop", re.IGNORECASE)


def _non_table_scenarios() -> list[str]:
    # the table and its variants (table_two_arms: two legs, two bolts) name their own objects
    table = ("table_assembly", "table_two_arms")
    shipped = [name for name in scenario.SHIPPED if name not in table]
    examples = [str(p) for p in sorted((REPO / "examples" / "scenarios").glob("*.yaml"))]
    return shipped + examples


def _table_words(text: str) -> list[str]:
    return sorted({m.group(0) for m in TABLE_WORDS.finditer(text)})


@pytest.mark.parametrize("spec", [*_non_table_scenarios(), "starter"])
def test_no_table_word_in_the_text_or_json_of_a_non_table_scenario(spec, tmp_path, capsys):
    if spec == "starter":
        assert main(["scenario", "new", str(tmp_path / "task")]) == 0
        spec = str(tmp_path / "task" / "scenario.yaml")
        capsys.readouterr()
    log = tmp_path / "run.jsonl"
    assert main(["run", spec, "--log", str(log), "--human", "cooperative", "--seed", "1"]) == 0
    text = capsys.readouterr().out
    assert main(["run", spec, "--json", "--quiet", "--human", "cooperative", "--seed", "1"]) == 0
    data = capsys.readouterr().out
    assert main(["replay", str(log)]) == 0
    replayed = capsys.readouterr().out
    assert main(["cell", spec, "--json", "--quiet"]) == 0
    cell = capsys.readouterr().out
    assert "by_agent" in json.loads(data) and "fixed_by_agent" in json.loads(cell)
    for what, out in (
        ("run", text),
        ("run --json", data),
        ("replay", replayed),
        ("cell --json", cell),
        ("the log", log.read_text()),
    ):
        assert _table_words(out) == [], f"{what} of {Path(spec).name}: {_table_words(out)}"


def test_the_table_keeps_its_words(capsys):
    assert main(["run", "table_assembly", "--json", "--quiet"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["legs_by_agent"] == data["fixed_by_agent"]
    assert main(["run", "table_assembly", "--quiet"]) == 0
    assert "legs connected by" in capsys.readouterr().out
