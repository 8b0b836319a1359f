"""Acceptance of the panel in a real headless browser (Debian's chromium).

The operator acts only by clicking the page; the page updates only through the websocket (a
marker set on the page before the clicks survives, so nothing was reloaded).
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("uvicorn")

from flexhrc.web.local import LocalCooperation, table_assembly
from flexhrc.web.server import PanelServer


@pytest.fixture
def serve() -> Iterator[Any]:
    running: list[tuple[PanelServer, LocalCooperation]] = []

    def make(coop: LocalCooperation) -> PanelServer:
        server = PanelServer(coop, "127.0.0.1", 0).start()
        running.append((server, coop))
        coop.start()
        return server

    yield make
    for server, coop in running:
        server.stop()
        coop.close()


def _mine(page: Any) -> Any:
    return page.locator("#suggestions tr.mine button.done")


def test_first_suggestion_then_done_advances_without_reload(
    serve: Any, open_page: Any, tmp_path: Path
) -> None:
    # no arm reaches bolt 1: an arm brings a leg to the middle, the operator screws it
    coop = table_assembly(4, unreachable_bolts=(1,), speed=40)
    server = serve(coop)
    page = open_page(server.url)
    first = page.locator("#suggestions tr.suggestion").first
    first.wait_for()
    assert first.get_attribute("data-element") == coop.snapshot()["suggestions"][0]["element"]
    page.evaluate("window.__marker = 'not reloaded'")
    done = _mine(page)
    done.wait_for()
    action = done.get_attribute("data-action")
    assert action is not None and action.startswith("pick_up(human, ")
    page.wait_for_selector("#banner:has-text('waiting for the operator')")
    shot = tmp_path / "panel.png"
    page.screenshot(path=str(shot), full_page=True)
    if os.environ.get("FLEXHRC_PANEL_SCREENSHOT"):  # docs/img/panel.png is made this way
        shutil.copy(shot, os.environ["FLEXHRC_PANEL_SCREENSHOT"])
    done.click()
    page.wait_for_selector("#suggestions tr.mine button.done[data-action^='screw(human, ']")
    page.wait_for_selector("#timeline-list li:has-text('pick_up(human, ')")
    assert page.evaluate("window.__marker") == "not reloaded"
    _mine(page).click()
    page.wait_for_selector("svg [data-id='connected_1'][data-status='met']")
    assert coop.kb.holds("filled", "bolt_1")
    coop.set_speed(1000)
    page.wait_for_selector("#outcome[data-outcome='solved']", timeout=20_000)
    assert page.evaluate("window.__marker") == "not reloaded"


def test_ill_do_this_makes_the_robot_leave_that_part(serve: Any, open_page: Any) -> None:
    coop = table_assembly(4, speed=1.5)  # slow arms: the click lands mid-action
    server = serve(coop)
    page = open_page(server.url)
    page.wait_for_selector("#suggestions tr[data-element='robot_1'][data-owner='robot']")
    arm = page.locator("#agents .agent[data-status='busy']").first.get_attribute("data-agent")
    page.locator("#suggestions button.take[data-take='human_1']").click()
    page.wait_for_selector("#suggestions tr[data-element='human_1'][data-owner='human']")
    page.wait_for_selector("#suggestions tr[data-element='robot_1'][data-owner='']")
    page.wait_for_selector("#timeline-list li[data-status='stopped']")
    snap = coop.snapshot()
    assert next(s for s in snap["suggestions"] if s["element"] == "human_1")["to"] == ["human"]
    taken_at = next(i for i, ev in enumerate(coop.events) if ev["type"] == "operator_takes")
    assert (
        not [  # the arm got no more work on that part
            ev
            for ev in coop.events[taken_at:]
            if ev["type"] == "command" and ev["element"] == "robot_1"
        ]
    )
    assert any(ev["type"] == "stop" and ev["agent"] == arm for ev in coop.events)
    _mine(page).click()  # pick_up
    page.wait_for_selector("#suggestions tr.mine button.done[data-action^='screw(human, ']")


def test_three_clients_show_the_same_state(serve: Any, open_page: Any) -> None:
    coop = table_assembly(4, unreachable_bolts=(1,), speed=40)
    server = serve(coop)
    pages = [open_page(server.url) for _ in range(3)]
    _mine(pages[0]).wait_for()
    _mine(pages[1]).click()  # one operator presses done; all three follow
    for p in pages:
        p.wait_for_selector("#suggestions tr.mine button.done[data-action^='screw(human, ']")
    for _ in range(200):  # let the arms finish what they do (they then wait for the operator)
        if coop.next_due() is None:
            break
        pages[2].wait_for_timeout(25)
    version = coop.snapshot()["version"]
    texts = []
    for p in pages:
        p.wait_for_function("(v) => window.__panel.version >= v", arg=version)
        texts.append(
            (
                p.inner_text("#suggestions"),
                p.inner_text("#agents"),
                p.inner_text("#timeline-list"),
                p.evaluate("window.__panel.version"),
            )
        )
    assert texts[0] == texts[1] == texts[2]


class _StaticBackend:
    """A backend with a fixed state: a hierarchical graph whose lower instances fold."""

    def __init__(self) -> None:
        from flexhrc.representation import AndOrGraph, HierarchicalGraph, OnlineGraph
        from flexhrc.web.snapshot import feasible_costs, graph_snapshot

        lower = AndOrGraph("Screwing", root="s_done")
        for n in ("s_leg", "s_done"):
            lower.add_node(n)
        lower.add_hyperarc("s_turn", ["s_leg"], "s_done", 1)
        top = AndOrGraph("Table", root="done")
        for n in ("leg", "done"):
            top.add_node(n)
        top.add_hyperarc("by_robot", ["leg"], "done", 1, lower="Screwing")
        top.add_hyperarc("by_human", ["leg"], "done", 2, lower="Screwing")
        graph = OnlineGraph(HierarchicalGraph({"Table": top, "Screwing": lower}, "Table"))
        graph.update(met_nodes=["leg"])
        self.state = {
            "outcome": "running",
            "reason": None,
            "waiting": None,
            "events": 0,
            "suggestions": [],
            "agents": [],
            "graph": graph_snapshot(graph, feasible_costs(graph)),
            "timeline": [],
            "objects": [],
            "facts": [],
            "version": 1,
        }

    def snapshot(self) -> dict[str, Any]:
        return self.state

    def subscribe(self, callback: Any) -> Any:
        return lambda: None

    def submit(self, body: Any) -> dict[str, Any]:
        raise AssertionError("not used")

    stop_robot = resume_robot = submit


def test_lower_graph_instances_fold(open_page: Any) -> None:
    with PanelServer(_StaticBackend(), "127.0.0.1", 0) as server:
        page = open_page(server.url)
        page.wait_for_selector("svg[data-graph='top'] [data-id='leg'][data-status='met']")
        lower = page.locator("details.instance[data-path='by_robot']")
        assert lower.locator("summary").inner_text().startswith("by_robot → Screwing")
        assert lower.get_attribute("open") is None  # folded, not drawn
        assert lower.locator("svg").count() == 0
        lower.locator("summary").click()
        page.wait_for_selector("svg[data-graph='by_robot'] [data-id='by_robot/s_leg']")
        assert page.locator("details.instance[data-path='by_human'] svg").count() == 0
