"""Acceptance of the panel in a real headless browser (Debian's chromium).

The operator acts only by clicking the page; the page updates only through the websocket (a
marker set on the page before the clicks survives, so nothing was reloaded).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("uvicorn")
pytest.importorskip("playwright")

from playwright.sync_api import TimeoutError as PlaywrightTimeout

from flexhrc.web.local import LocalPanel, PanelConfig, serve_panel, table_legs
from flexhrc.web.server import PanelServer
from tests.conftest import subprocess_env
from tests.web.helpers import until, waiting_for_operator


@pytest.fixture
def serve() -> Iterator[Any]:
    """``serve(scenario, speed)`` -> a running panel (:func:`serve_panel` on port 0)."""
    running: list[LocalPanel] = []

    def make(scenario: Any, speed: float) -> LocalPanel:
        config = PanelConfig(scenario, speed=speed, simulator="analytic", port=0)
        running.append(serve_panel(config))
        return running[-1]

    yield make
    for panel in running:
        panel.close()


def _mine(page: Any) -> Any:
    return page.locator("#suggestions tr.mine button.done")


def test_first_suggestion_then_done_advances_without_reload(
    serve: Any, open_page: Any, tmp_path: Path
) -> None:
    # no arm reaches bolt 1: an arm brings a leg to the middle, the operator screws it
    coop = serve(table_legs(4, unreachable_bolts=(1,)), speed=40)
    page = open_page(coop.url)
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
    assert coop.cell.kb.holds("filled", "bolt_1")
    coop.set_speed(1000)
    page.wait_for_selector("#outcome[data-outcome='solved']", timeout=20_000)
    assert page.evaluate("window.__marker") == "not reloaded"


def test_ill_do_this_makes_the_robot_leave_that_part(serve: Any, open_page: Any) -> None:
    coop = serve(table_legs(4), speed=1.5)  # slow arms: the click lands mid-action
    page = open_page(coop.url)
    page.wait_for_selector("#suggestions tr[data-element='robot_1'][data-owner='robot']")
    arm = page.locator("#agents .agent[data-status='busy']").first.get_attribute("data-agent")
    page.locator("#suggestions button.take[data-take='human_1']").click()
    page.wait_for_selector("#suggestions tr[data-element='human_1'][data-owner='human']")
    page.wait_for_selector("#suggestions tr[data-element='robot_1'][data-owner='']")
    page.wait_for_selector("#timeline-list li[data-status='stopped']")
    snap = coop.snapshot()
    assert next(s for s in snap["suggestions"] if s["element"] == "human_1")["to"] == ["human"]
    events = list(coop.cell.events)
    taken_at = next(i for i, ev in enumerate(events) if ev.kind == "human_take")
    assert (
        not [  # the arm got no more work on that part
            ev
            for ev in events[taken_at:]
            if ev.kind == "command" and ev.body["element"] == "robot_1"
        ]
    )
    assert any(ev.kind == "stop" and ev.body["agent"] == arm for ev in events)
    _mine(page).click()  # pick_up
    page.wait_for_selector("#suggestions tr.mine button.done[data-action^='screw(human, ']")


def test_three_clients_show_the_same_state(serve: Any, open_page: Any) -> None:
    coop = serve(table_legs(4, unreachable_bolts=(1,)), speed=40)
    pages = [open_page(coop.url) for _ in range(3)]
    _mine(pages[0]).wait_for()
    _mine(pages[1]).click()  # one operator presses done; all three follow
    for p in pages:
        p.wait_for_selector("#suggestions tr.mine button.done[data-action^='screw(human, ']")
    until(coop, waiting_for_operator)  # the arms finish what they do, then wait for the operator
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


BALL_IN_BOX = Path(__file__).resolve().parents[2] / "examples" / "scenarios" / "ball_in_box.yaml"


def _announced_url(log: Path, proc: subprocess.Popen[str], timeout: float = 30.0) -> str:
    """The address the panel printed (it bound port 0 itself: no port picked beforehand)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        m = re.search(r"panel: (http://127\.0\.0\.1:\d+/)", log.read_text())
        if m:
            return m.group(1)
        if proc.poll() is not None:
            break
        time.sleep(0.05)  # polling a file another process writes
    raise AssertionError(f"no panel address; log:\n{log.read_text()[-2000:]}")


def _click_done_until_solved(page: Any, timeout: float = 60.0) -> list[str]:
    """Press 'done' on whatever the page asks the operator, until it shows the end."""
    clicked: list[str] = []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if page.locator("#outcome[data-outcome='solved']").count():
            return clicked
        action = page.evaluate(
            "document.querySelector('#suggestions tr.mine button.done')?.dataset.action ?? null"
        )
        if action and action not in clicked:
            try:
                page.click(f"#suggestions button.done[data-action='{action}']", timeout=2_000)
                clicked.append(action)
            except PlaywrightTimeout:
                continue  # gone meanwhile (the page redrew); look again
        page.wait_for_timeout(50)
    raise AssertionError(f"not solved; clicked {clicked}")


@pytest.mark.slow
def test_flexhrc_panel_solves_another_scenario_with_the_person_and_the_arms(
    tmp_path: Path, open_page: Any
) -> None:
    """`flexhrc panel kitchen_drawer`: the drawer of three graph layers, both arms on the wall
    clock, the person pressing 'done' on the page for the operator's steps (the roller slides
    only they mount)."""
    log = tmp_path / "panel.err"
    proc = subprocess.Popen(
        [sys.executable, "-m", "flexhrc", "panel", "kitchen_drawer", "--speed", "20",
         "--simulator", "analytic", "--web", "127.0.0.1:0", "--exit-when-done", "--json"],
        stdout=subprocess.PIPE, stderr=log.open("w"), text=True, env=subprocess_env(),
    )  # fmt: skip
    try:
        page = open_page(_announced_url(log, proc))
        page.evaluate("window.__marker = 'not reloaded'")
        clicked = _click_done_until_solved(page)
        assert page.evaluate("window.__marker") == "not reloaded"
        out, _ = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait(10)
    assert proc.returncode == 0, log.read_text()[-2000:]
    data = json.loads(out)
    assert data["outcome"] == "solved" and data["scenario"] == "kitchen_drawer"
    assert data["human_actions"] == len(clicked) > 0  # each click, stored as the operator's
    assert any(a.startswith("mount(human, ") for a in clicked)
    assert data["robot_actions"] > 0
    assert data["by_agent"]["left"] + data["by_agent"]["right"] > 0
    assert data["url"].startswith("http://127.0.0.1:") and ":0/" not in data["url"]


def test_ill_do_this_then_done_solves_ball_in_box(serve: Any, open_page: Any) -> None:
    """Not the table: the arm goes for the ball, the person says "I'll do this" on picking it
    up by hand, the arm stops, the person picks it up and drops it in (two 'done')."""
    coop = serve(str(BALL_IN_BOX), speed=0.5)  # slow arm: the click lands mid-action
    page = open_page(coop.url)
    page.wait_for_selector("#suggestions tr[data-element='robot_picks'][data-owner='robot']")
    page.locator("#suggestions button.take[data-take='human_picks']").click()
    page.wait_for_selector("#suggestions tr[data-element='human_picks'][data-owner='human']")
    page.wait_for_selector("#timeline-list li[data-status='stopped']")
    coop.set_speed(50)
    clicked = _click_done_until_solved(page, timeout=30)
    assert clicked == ["pick_up(human, ball)", "release(human, ball, box)"]
    assert coop.wait(10)
    report = coop.report()
    assert report.outcome == "solved"
    assert report.summary["human_actions"] == 2
    assert coop.cell.kb.holds("in", "ball", "box")
    assert any(ev.kind == "human_take" for ev in coop.cell.events)


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


def test_start_done_and_not_now_at_the_page(serve: Any, open_page: Any, tmp_path: Path) -> None:
    """Issue 22: the person clicks "start" and "done" on the first lid: its report carries the
    start, the human lane its time; then "not now" on the second: the arm carries it."""
    from tests.cell.test_answers import LIDS

    path = tmp_path / "lids.yaml"
    path.write_text(LIDS)
    coop = serve(str(path), speed=5)
    page = open_page(coop.url)
    start = page.locator("#suggestions tr.mine button.reply.start")
    start.wait_for()
    assert _mine(page).get_attribute("data-action") == "carry(human, lid_a, box)"
    start.click()
    page.wait_for_selector('#message:has-text("you said I\'m starting")')
    _mine(page).click()
    page.wait_for_selector(
        "#suggestions tr.mine button.done[data-action='carry(human, lid_b, box)']", timeout=20_000
    )
    page.locator("#suggestions tr.mine button.reply.decline").click()
    page.wait_for_selector("#outcome[data-outcome='solved']", timeout=20_000)
    page.wait_for_selector("#timeline-list li:has-text('carry(arm, lid_b, box)')")
    events = coop.cell.events
    assert [e.body["element"] for e in events if e.kind == "human_declined"] == ["place_b"]
    [said] = [e for e in events if e.kind == "human_reply" and e.body["reply"] == "start"]
    [report] = [e.body for e in events if e.kind == "human_action"]
    assert report["start"] == round(said.t, 6) and report["t"] > report["start"]
    assert coop.report().summary["timing"]["human_actions_s"] > 0


def test_a_request_left_unanswered_goes_to_the_arm_at_the_page(
    open_page: Any, tmp_path: Path
) -> None:
    """Issue 22: the scenario's ``answer_timeout: 5``; the page is open (and marked) before the
    cooperation starts, the person's request appears and nobody clicks: 5 s later the step is
    declined (``why: timeout``), the request leaves the page and the arm's carry shows in the
    timeline, all through the websocket (the marker survives: nothing was reloaded)."""
    from tests.cell.test_answers import LIDS

    path = tmp_path / "lids.yaml"
    path.write_text(LIDS.replace("simulator: analytic", "simulator: analytic\nanswer_timeout: 5"))
    coop = LocalPanel(str(path), speed=1.0, simulator="analytic")
    try:
        coop.server = PanelServer(coop, "127.0.0.1", 0).start()
        page = open_page(coop.url)
        page.wait_for_selector("#link.link-up")  # the websocket is up before anything happens
        page.evaluate("window.__marker = 'not reloaded'")
        coop.start()
        asked = page.locator(
            "#suggestions tr.mine button.done[data-action='carry(human, lid_a, box)']"
        )
        asked.wait_for(
            timeout=20_000
        )  # the request, shown for 5 s of the cell's clock (1 s a second)
        page.wait_for_selector(
            "#timeline-list li:has-text('carry(arm, lid_a, box)')", timeout=20_000
        )
        asked.wait_for(state="detached")  # the request left the page
        page.wait_for_selector("#outcome[data-outcome='solved']", timeout=30_000)
        assert page.evaluate("window.__marker") == "not reloaded"
        events = coop.cell.events
        [reply] = [e for e in events if e.kind == "human_reply"]
        assert reply.body["why"] == "timeout" and reply.body["reply"] == "decline"
        [asked_at] = [e.t for e in events if e.kind == "suggestion"][:1]
        assert reply.t >= asked_at + 5.0
        [declined] = [e.body for e in events if e.kind == "human_declined"]
        assert declined["element"] == "place_a" and "no answer after 5 s" in declined["reason"]
        [cmd] = [e.body for e in events if e.kind == "command" and e.body["element"] == "place_a"]
        assert cmd["agents"] == ["arm"]
    finally:
        coop.close()
