"""The cell in 3D on the operator's view (issue 24, item 2), in headless Chromium (WebGL through
SwiftShader): three.js served by flexhrc itself, the arms from the project's robot model with
their joint states, the objects of the knowledge base with their sizes, the person's hand."""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("uvicorn")
pytest.importorskip("playwright")

from flexhrc.web.local import LocalPanel, PanelConfig, serve_panel, table_legs
from tests.cell.test_answers import LIDS

# drawn and read in one task: the canvas keeps no drawing buffer between frames (it costs)
PIXELS = """(() => { window.__scene3d.draw();
  return document.querySelector('#scene3d canvas').toDataURL('image/png'); })()"""
MESHES = """(() => window.__scene3d.scene.children.flatMap((c) => c.children || [])
  .filter((m) => m.userData && m.userData.id).map((m) => m.userData.id))()"""


@pytest.fixture
def serve() -> Iterator[Any]:
    running: list[LocalPanel] = []

    def make(scenario: Any, speed: float, simulator: str = "analytic") -> LocalPanel:
        config = PanelConfig(scenario, speed=speed, simulator=simulator, port=0)
        running.append(serve_panel(config))
        return running[-1]

    yield make
    for panel in running:
        panel.close()


def _wait(page: Any, check: str, what: str, timeout: float = 60.0) -> Any:
    """Poll ``check`` in the page until it is truthy (the page's CSP forbids wait_for_function's
    eval); ``timeout`` bounds the wait, it is no timing assertion."""
    deadline = time.monotonic() + timeout
    while not (value := page.evaluate(check)):
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        page.wait_for_timeout(100)
    return value


def test_the_arms_are_drawn_from_their_joint_states_and_move(serve: Any, open_page: Any) -> None:
    pytest.importorskip("pinocchio")
    coop = serve(table_legs(4), speed=4, simulator="kinematic")
    page = open_page(coop.url, view=None)
    chain = "(window.__panel.state?.scene?.robots || []).map((r) => JSON.stringify(r.chain))"
    first = _wait(page, f"{chain}.find((c) => c !== 'null')", "a joint state")
    assert len(__import__("json").loads(first)) == 8  # 7 joints and the tool centre point
    before = page.evaluate(PIXELS)
    _wait(page, f"{chain}.find((c) => c !== 'null') !== {first!r}", "the arm to move")
    page.wait_for_timeout(100)  # the redraw follows the state in the same task; let it land
    assert page.evaluate(PIXELS) != before  # the pixels changed with the joint state
    # every object of the knowledge base is in the scene (agents are drawn as arms and hands)
    objects = {o["id"] for o in coop.snapshot()["scene"]["objects"]}
    assert {"tabletop", "leg1", "bolt_1", "middle"} <= objects
    assert set(page.evaluate(MESHES)) == objects


def test_any_scenario_is_drawn_without_a_robot_model(
    serve: Any, open_page: Any, tmp_path: Path
) -> None:
    path = tmp_path / "lids.yaml"
    path.write_text(LIDS)
    coop = serve(str(path), speed=5)
    page = open_page(coop.url, view=None)
    page.wait_for_selector("#turn[data-turn='yours']")
    scene = coop.snapshot()["scene"]
    assert [r["name"] for r in scene["robots"]] == ["arm"] and scene["robots"][0]["chain"] is None
    assert scene["people"] == [{"name": "human", "hand": [1.0, 0.0, 0.1]}]
    assert {o["id"]: o["size"] for o in scene["objects"]}["box"] == {
        "length": 0.3,
        "width": 0.2,
        "height": 0.15,
    }
    _wait(page, "window.__panel.frames > 0", "a frame")
    assert sorted(page.evaluate(MESHES)) == ["box", "lid_a", "lid_b"]
    # the canvas shows something: more than the background colour
    colours = page.evaluate(
        """(() => { window.__scene3d.draw(); const c = document.querySelector('#scene3d canvas');
        const g = document.createElement('canvas'); g.width = c.width; g.height = c.height;
        const x = g.getContext('2d'); x.drawImage(c, 0, 0);
        const d = x.getImageData(0, 0, g.width, g.height).data; const seen = new Set();
        for (let i = 0; i < d.length; i += 4 * 97) seen.add(d[i] + ',' + d[i + 1] + ',' + d[i + 2]);
        return seen.size; })()"""
    )
    assert colours > 10


def test_three_js_is_served_by_flexhrc_with_its_licence(serve: Any) -> None:
    import urllib.request

    coop = serve(table_legs(2), speed=5)
    for path in ("/static/vendor/three/three.module.min.js", "/static/vendor/three/LICENSE"):
        with urllib.request.urlopen(coop.url.split("?")[0].rstrip("/") + path, timeout=10) as r:
            body = r.read()
        assert r.status == 200 and body
    assert b"MIT License" in body


def test_the_next_motion_is_drawn_before_the_arm_moves_and_goes_when_it_ends(
    serve: Any, open_page: Any, tmp_path: Path
) -> None:
    path = tmp_path / "lids.yaml"
    path.write_text(LIDS)
    coop = serve(str(path), speed=1)  # the arm's 2 s carry takes 2 s on the page
    page = open_page(coop.url, view=None)
    page.wait_for_selector("#turn[data-turn='yours']")
    assert page.evaluate("window.__scene3d.planned()") == {}  # nothing dispatched yet
    coop.submit({"reply": "decline"})  # the arm carries lid a
    drawn = _wait(page, "window.__scene3d.planned().arm", "the planned path")
    assert drawn == 2  # from the hand to the box: the branch simulation's path
    [robot] = [r for r in page.evaluate("window.__panel.state.scene.robots") if r["planned"]]
    assert robot["planned"]["action"] == "carry(arm, lid_a, box)"
    assert robot["planned"]["path"][-1] == [1.1, 0.0, 0.0]  # the box: the carry's moves_to
    assert robot["planned"]["path"][0] == robot["hand"]  # from where the hand is
    assert page.evaluate(
        "window.__scene3d.scene.children.flatMap((c) => c.children || [])"
        ".some((m) => m.userData.ghost === 'arm')"
    )
    # the command ends: the path and the ghost go
    _wait(page, "!window.__scene3d.planned().arm", "the path to go", timeout=30)
    ended = [e for e in coop.cell.events if e.kind == "ack"]
    assert ended and ended[0].body["status"] == "done"
