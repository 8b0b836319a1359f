"""The panel's cases of the second probe (2026-12-02): sections 4 and 9.

* W27-W29: the same "done" pressed again (a double click, a second tab, a retried request) is
  recorded once and answered ``already_done``, on the wall-clock panel and on the ordered cell
  behind ``flexhrc cell --web``;
* WS07: idle websockets never keep the operator's ``/api/stop`` from an answer.
"""

from __future__ import annotations

import asyncio
import json
import threading
import urllib.error
import urllib.request
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import pytest

from flexhrc.cell.store import read_store
from flexhrc.web.app import MAX_WEBSOCKETS, TRY_AGAIN_LATER
from tests.web.helpers import TABLE_HUMAN_BOLT_1, human_next, until, waiting_for_operator
from tests.web.test_live import Running

pytest.importorskip("uvicorn")
websockets_client = pytest.importorskip("websockets.asyncio.client")
ConnectionClosed = pytest.importorskip("websockets.exceptions").ConnectionClosed


def _human_actions(cell: Any) -> list[str]:
    return [str(ev.body["action"]) for ev in cell.events if ev.kind == "human_action"]


def _human_timeline(snap: dict[str, Any]) -> list[str]:
    return [t["action"] for t in snap["timeline"] if t["agents"] == ["human"]]


# -- W27-W29: one step, one record ------------------------------------------------------------


def test_w29_done_pressed_again_is_recorded_once(local_panel: Any) -> None:
    panel = local_panel(TABLE_HUMAN_BOLT_1)
    until(panel, waiting_for_operator)
    (first,) = human_next(panel)
    assert first == "pick_up(human, leg3)"
    answers = [panel.submit({"action": first}) for _ in range(3)]
    assert answers[0] == {"ok": True, "action": first, "outcome": "running"}
    for again in answers[1:]:  # the same step: already done, nothing recorded
        assert again["ok"] and again["already_done"] is True and again["action"] == first
    assert _human_actions(panel.cell) == [first]
    snap = until(panel, lambda s: bool(human_next(panel)))
    assert _human_timeline(snap) == [first]
    # the operator goes on with the step the banner asks for; the run ends as without repeats
    (second,) = human_next(panel)
    assert second == "screw(human, leg3, bolt_1)"
    assert "already_done" not in panel.submit({"action": second})
    assert panel.submit({"action": second})["already_done"] is True
    assert panel.wait(60)
    assert panel.cell.tm.outcome == "solved"
    assert _human_actions(panel.cell) == [first, second]
    assert panel.report().summary["human_actions"] == 2


def test_w28_twelve_concurrent_done_clicks_are_one_record(local_panel: Any) -> None:
    panel = local_panel(TABLE_HUMAN_BOLT_1)
    until(panel, waiting_for_operator)
    (first,) = human_next(panel)
    with ThreadPoolExecutor(12) as pool:
        answers = list(pool.map(lambda _: panel.submit({"action": first}), range(12)))
    assert all(a["ok"] and a["action"] == first for a in answers)
    assert sum(1 for a in answers if not a.get("already_done")) == 1
    assert _human_actions(panel.cell) == [first]
    assert _human_timeline(until(panel, lambda s: bool(human_next(panel)))) == [first]


@pytest.fixture
def ordered_cell(tmp_path: Path) -> Iterator[Running]:
    r = Running(tmp_path, TABLE_HUMAN_BOLT_1)
    yield r
    r.cell.request_stop("the test ended")
    r.thread.join(30)
    r.panel.close()
    r.cell.close()
    r.store.close()


def test_w27_concurrent_done_on_the_ordered_cell_stores_one_human_action(
    ordered_cell: Running,
) -> None:
    # the ordered loop of `flexhrc cell --web` queues an input for its time: the clicks after
    # the first are checked while the first still waits in the queue
    r = ordered_cell
    until(r.panel, waiting_for_operator)
    (first,) = human_next(r.panel)
    with ThreadPoolExecutor(12) as pool:
        answers = list(pool.map(lambda _: r.panel.submit({"action": first}), range(12)))
    assert sum(1 for a in answers if not a.get("already_done")) == 1
    until(r.panel, lambda s: first in _human_timeline(s))
    (second,) = human_next(r.panel)
    r.panel.submit({"action": second})
    r.thread.join(60)
    assert r.summary["outcome"] == "solved"
    stored = [ev.body["action"] for ev in read_store(r.store_path) if ev.kind == "human_action"]
    assert stored == [first, second]


def test_w29_the_same_action_asked_again_is_new_work(local_panel: Any) -> None:
    """A repeat is refused as a record only while the step is done: when the manager asks the
    same action again (re-planned), pressing "done" on it is recorded."""
    panel = local_panel(TABLE_HUMAN_BOLT_1)
    until(panel, waiting_for_operator)
    (first,) = human_next(panel)
    panel.submit({"action": first})
    live = panel.backend
    assert panel.call(lambda: live._already_done(first, "human"))

    def asked_again() -> bool:  # on the cell's thread: as if the manager asked it again
        ex = next(ex for ex in panel.cell.tm.executions.values() if ex.owner == "human")
        index, ex.next_index = ex.next_index, 0
        try:
            return bool(live._already_done(first, "human"))
        finally:
            ex.next_index = index

    assert panel.call(asked_again) is False


def test_w28_a_double_click_in_the_browser_is_one_record(tmp_path: Path, open_page: Any) -> None:
    from flexhrc.web.local import PanelConfig, serve_panel

    scenario = tmp_path / "table.yaml"
    scenario.write_text(TABLE_HUMAN_BOLT_1)
    panel = serve_panel(PanelConfig(scenario=str(scenario), port=0, speed=40, simulator="analytic"))
    try:
        until(panel, waiting_for_operator)
        (first,) = human_next(panel)
        page = open_page(panel.url)
        page.wait_for_selector(f"#suggestions tr.mine button.done[data-action='{first}']")
        # two clicks on the one button before the page can redraw (a double click); the page's
        # answers are collected as they come (in either order: two requests at once)
        page.evaluate(
            """(action) => {
                window.__answers = [];
                const fetch0 = window.fetch;
                window.fetch = async (...args) => {
                    const r = await fetch0(...args);
                    r.clone().json().then((d) => {
                        window.__answers.push(d);
                        document.body.dataset.answers = String(window.__answers.length);
                    });
                    return r;
                };
                const b = document.querySelector(
                    `#suggestions tr.mine button.done[data-action='${action}']`);
                b.click();
                b.click();
            }""",
            first,
        )
        page.wait_for_selector("body[data-answers='2']", state="attached")
        answers = page.evaluate("window.__answers")
        assert sorted(bool(a.get("already_done")) for a in answers) == [False, True], answers
        assert all(a["ok"] and a["action"] == first for a in answers)
        message = page.locator("#message").text_content()
        assert message in (f"done: {first}", f"already done: {first}")
        page.wait_for_selector("#suggestions tr.mine button.done[data-action^='screw(human, ']")
        assert _human_actions(panel.cell) == [first]
        timeline = page.locator("#timeline-list li", has_text="pick_up(human, ")
        assert timeline.count() == 1
    finally:
        panel.close()


# -- WS07: the stop is always answered -----------------------------------------------------------


def _post(port: int, path: str, body: dict[str, Any]) -> tuple[int, dict[str, Any]]:
    req = urllib.request.Request(
        f"http://127.0.0.1:{port}{path}",
        data=json.dumps(body).encode(),
        headers={"Content-Type": "application/json"},
    )
    try:
        with urllib.request.urlopen(req, timeout=30) as resp:
            return resp.status, json.loads(resp.read())
    except urllib.error.HTTPError as exc:
        return exc.code, json.loads(exc.read())


def _run(coro: Any) -> Any:
    """``asyncio.run(coro)`` on a thread of its own: the browser tests' Playwright keeps an
    event loop on this one."""
    with ThreadPoolExecutor(1) as pool:
        return pool.submit(asyncio.run, coro).result()


def _get(port: int, path: str) -> tuple[int, bytes]:
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}{path}", timeout=30) as resp:
            return resp.status, resp.read()
    except urllib.error.HTTPError as exc:
        return exc.code, exc.read()


def test_ws07_260_idle_websockets_do_not_deny_the_operators_stop(tmp_path: Path) -> None:
    from flexhrc.web.local import PanelConfig, serve_panel

    scenario = tmp_path / "table.yaml"
    scenario.write_text(TABLE_HUMAN_BOLT_1)
    # speed 1: the cooperation still runs when the stop comes
    panel = serve_panel(PanelConfig(scenario=str(scenario), port=0, simulator="analytic"))
    try:
        assert panel.server is not None
        port = panel.server.port
        url = f"ws://127.0.0.1:{port}/ws"

        async def flood() -> tuple[int, list[Any], tuple[int, dict[str, Any]], int]:
            sockets = [await websockets_client.connect(url) for _ in range(260)]
            try:
                kept, refused = [], []
                for ws in sockets:  # each is sent the snapshot, or closed with the reason
                    try:
                        json.loads(await ws.recv())
                        kept.append(ws)
                    except ConnectionClosed as exc:
                        refused.append(exc.rcvd)
                stop = await asyncio.to_thread(_post, port, "/api/stop", {"robot": "left"})
                page, _ = await asyncio.to_thread(_get, port, "/")
                return len(kept), refused, stop, page
            finally:
                for ws in sockets:
                    await ws.close()

        kept, refused, stop, page = _run(flood())
        assert stop == (200, {"ok": True, "stopped": "left"})
        assert page == 200
        assert kept == MAX_WEBSOCKETS
        assert len(refused) == 260 - MAX_WEBSOCKETS
        assert all(c is not None and c.code == TRY_AGAIN_LATER for c in refused)
        assert "too many open panels" in refused[0].reason

        async def one_more() -> dict[str, Any]:  # the places free again once pages close
            async with websockets_client.connect(url) as ws:
                return dict(json.loads(await ws.recv()))

        assert _run(one_more())["outcome"] == "running"
    finally:
        panel.close()


class _StuckBackend:
    """A backend whose snapshot blocks (a cell that does not answer) once armed."""

    def __init__(self) -> None:
        self.armed = False
        self.release = threading.Event()
        self.inside = threading.Semaphore(0)
        self.stopped: list[str] = []

    def snapshot(self) -> dict[str, Any]:
        if self.armed:
            self.inside.release()
            self.release.wait(30)
        return {"outcome": "running", "suggestions": [], "agents": [], "events": 0}

    def subscribe(self, callback: Callable[[], None]) -> Callable[[], None]:
        return lambda: None

    def submit(self, body: Any) -> dict[str, Any]:
        return {"ok": True}

    def stop_robot(self, name: str) -> dict[str, Any]:
        self.stopped.append(name)
        return {"ok": True, "stopped": name}

    def resume_robot(self, name: str) -> dict[str, Any]:
        return {"ok": True, "resumed": name}


@pytest.fixture
def stuck() -> Iterator[tuple[_StuckBackend, int]]:
    from flexhrc.web.server import PanelServer

    backend = _StuckBackend()
    # 40 requests in progress: as many as the shared thread pool has threads (anyio's default)
    server = PanelServer(backend, port=0, max_requests=40).start()
    try:
        yield backend, server.port
    finally:
        backend.release.set()
        server.stop()


def test_ws07_requests_that_wait_for_the_cell_do_not_deny_the_stop(
    stuck: tuple[_StuckBackend, int],
) -> None:
    backend, port = stuck
    backend.armed = True
    with ThreadPoolExecutor(41) as pool:
        waiting = [pool.submit(_get, port, "/api/state") for _ in range(40)]
        for _ in range(40):  # every thread of the shared pool now waits for the cell
            assert backend.inside.acquire(timeout=30)
        status, body = _get(port, "/api/state")
        assert status == 503 and b"busy" in body  # one more is refused, and says why
        assert _post(port, "/api/stop", {"robot": "left"}) == (
            200,
            {"ok": True, "stopped": "left"},
        )
        assert _post(port, "/api/resume", {"robot": "left"})[0] == 200
        backend.release.set()
        assert all(f.result(30)[0] == 200 for f in waiting)
    assert backend.stopped == ["left"]
