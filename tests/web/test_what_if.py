"""'What if I do this?' (issue 24, item 4): the Task Manager tried on a copy of its state says
what the robots would do if the person did a step or took a part — in words and as paths —
and nothing changes: no event, no new state."""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any

import pytest

from flexhrc.web import PanelInputError
from flexhrc.web.backend import parse_what_if_body
from flexhrc.web.local import LocalPanel, PanelConfig, serve_panel, table_legs
from tests.web.helpers import until


@pytest.fixture
def serve() -> Iterator[Any]:
    running: list[LocalPanel] = []

    def make(scenario: Any, speed: float) -> LocalPanel:
        running.append(
            serve_panel(PanelConfig(scenario, speed=speed, simulator="analytic", port=0))
        )
        return running[-1]

    yield make
    for panel in running:
        panel.close()


def test_a_take_what_if_says_what_each_arm_would_do_and_changes_nothing(serve: Any) -> None:
    panel = serve(table_legs(4), speed=2)
    snap = until(panel, lambda s: any(o["element"] == "human_1" for o in s["offers"]))
    events = len(panel.cell.events)
    answer = panel.what_if({"take": "human_1"})
    assert answer["ok"] and answer["take"] == "human_1"
    robots = {r["agent"]: r for r in answer["robots"]}
    assert set(robots) == {"left", "right"}
    for r in robots.values():  # each arm: a step in plain words, or waiting
        assert r["text"] is None or ("(" not in r["text"] and "_" not in r["text"])
        assert r["path"] is None or len(r["path"]) == 2
    assert answer["text"].endswith(".") and (
        "would" in answer["text"] or "goes on" in answer["text"]
    )
    # nothing happened: no event, and the manager's own executions are as they were
    assert not [e for e in panel.cell.events[events:] if e.kind in ("human_take", "taken")]
    assert "human_1" not in panel.cell.tm.executions or (
        panel.cell.tm.executions["human_1"].owner != "human"
    )
    assert snap["offers"][0]["element"] in {o["element"] for o in panel.snapshot()["offers"]}


def test_an_action_what_if_is_checked_like_a_report(local_panel: Any) -> None:
    from tests.cell.test_answers import LIDS

    panel = local_panel(LIDS, speed=5)
    until(panel, lambda s: any(g["owner"] == "human" and g["next"] for g in s["suggestions"]))
    answer = panel.what_if({"action": "carry(human, lid_a, box)"})
    assert answer["robots"][0]["agent"] == "arm"
    with pytest.raises(PanelInputError, match="would not advance"):
        panel.what_if({"action": "carry(human, lid_b, box)"})  # lid b's part is not feasible
    with pytest.raises(PanelInputError, match="unknown action"):
        panel.what_if({"action": "fly(human)"})
    with pytest.raises(PanelInputError, match="unknown hyper-arc"):
        panel.what_if({"take": "nowhere"})
    with pytest.raises(PanelInputError, match="a what-if asks about a step"):
        parse_what_if_body(json.dumps({"reply": "decline"}).encode())
    assert [e.kind for e in panel.cell.events].count("human_action") == 0


def test_what_if_on_the_page_answers_in_words_and_draws_the_paths(
    serve: Any, open_page: Any
) -> None:
    pytest.importorskip("playwright")
    coop = serve(table_legs(4), speed=1.5)
    page = open_page(coop.url, view=None)
    page.locator("#op-take button.whatif[data-whatif='human_1']").click()
    page.wait_for_selector("#whatif-text:has-text('If you do this: ')")
    answer = page.evaluate("window.__panel.whatIf")
    assert answer["take"] == "human_1"
    drawn = page.evaluate("window.__scene3d.planned()")
    moving = [r["agent"] for r in answer["robots"] if r["path"]]
    assert all(drawn.get("what if " + a) == 2 for a in moving)
    assert not [e for e in coop.cell.events if e.kind == "human_take"]  # only asked
