"""Every shipped scenario, every profile, ten seeds: solved, with the invariants from the log."""

from __future__ import annotations

import json

import pytest

from flexhrc import scenario
from flexhrc.cli import main

from .invariants import check_invariants

PROFILES = ("passive", "takeover", "cooperative", "random")
KEYS = {
    "outcome",
    "reason",
    "robot_actions",
    "human_actions",
    "decisions",
    "branches_simulated",
    "timing",
    "solved_hyperarcs",
    "by_agent",
}


@pytest.mark.parametrize("name", scenario.SHIPPED)
@pytest.mark.parametrize("profile", PROFILES)
def test_shipped_scenario_solved_for_ten_seeds(name, profile, tmp_path, capsys):
    sc = scenario.load(name)
    for seed in range(10):
        log = tmp_path / f"{seed}.jsonl"
        code = main(
            ["run", name, "--human", profile, "--seed", str(seed), "--json", "--quiet",
             "--log", str(log)]
        )  # fmt: skip
        data = json.loads(capsys.readouterr().out)
        assert code == 0 and data["outcome"] == "solved", (name, profile, seed, data["reason"])
        assert set(data) >= KEYS
        events = [json.loads(line) for line in log.read_text().splitlines()]
        check_invariants(sc, events)
        solved = [e for e in events if e["type"] == "solved"]
        assert data["solved_hyperarcs"] == [
            {"hyperarc": e["element"], "agent": "+".join(e["agents"]), "t": e["t"]} for e in solved
        ]
        counts = {a: 0 for a in sc.domain.agents}
        for e in solved:
            for a in e["agents"]:
                counts[a] += 1
        assert data["by_agent"] == counts


def test_robot_and_operator_both_take_part_somewhere():
    """Across profiles and seeds each shipped scenario is a cooperation, not a solo."""
    for name in scenario.SHIPPED:
        sc = scenario.load(name)
        robots, humans = 0, 0
        for profile in PROFILES:
            for seed in range(3):
                by = scenario.run(sc, profile=profile, seed=seed).summary["by_agent"]
                humans += sum(n for a, n in by.items() if sc.domain.agent(a).is_human)
                robots += sum(n for a, n in by.items() if not sc.domain.agent(a).is_human)
        assert robots > 0 and humans > 0, name


def test_the_kitchen_drawer_has_two_layers_of_the_authors_lower_graphs():
    sc = scenario.load("kitchen_drawer")
    stats = sc.graph.stats()
    assert stats["layers"] == 3 and stats["instances"] == 5  # RollerAssembly used twice
    result = scenario.run(sc, seed=0)
    deep = [
        x["hyperarc"] for x in result.summary["solved_hyperarcs"] if x["hyperarc"].count("/") == 2
    ]
    assert "build_drawer/h8/h1" in deep and "build_drawer/h9/h4" in deep


def test_the_shipped_table_file_is_what_the_generator_writes():
    from flexhrc.scenario.builtin.table import shipped_documents

    folder = scenario.shipped_path("table_assembly").parent
    scenario_text, graph_text = shipped_documents()
    assert (folder / "table_assembly.yaml").read_text() == scenario_text
    assert (folder / "table_assembly.graph.yaml").read_text() == graph_text
