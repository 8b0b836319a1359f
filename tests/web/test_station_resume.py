"""The operator station survives a restart of the manager (issue 24, item 5): `flexhrc cell
--web` as a process, the person at the page, the manager killed (SIGKILL) after the person's
first step and started again with `--resume` on the same ports: the page — never reloaded —
reconnects, shows the step the store says is next, and the cooperation ends solved with each of
the person's steps stored once."""

from __future__ import annotations

import json
import os
import signal
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("zenoh")
pytest.importorskip("uvicorn")
pytest.importorskip("playwright")

from tests.cell.helpers import (
    TABLE_HUMAN_BOLT,
    cell,
    finish,
    kill_all,
    listening_port,
    robot,
    rows,
    wait_until,
)

pytestmark = pytest.mark.slow


def test_a_manager_restart_with_resume_keeps_the_page_and_the_work(
    tmp_path: Path, open_page: Any
) -> None:
    scenario = tmp_path / "table.yaml"
    scenario.write_text(TABLE_HUMAN_BOLT)  # no arm reaches bolt 2: the person screws a leg
    store, ready = tmp_path / "cell.db", tmp_path / "cell.ready"
    manager = cell(str(scenario), 0, store, "--web", "127.0.0.1:0", log=tmp_path / "cell.err",
                   ready=ready)  # fmt: skip
    procs = [manager]
    try:
        port = listening_port(ready, manager)
        url = json.loads(ready.read_text())["web"]
        web = url.rstrip("/").rsplit(":", 1)[1]
        procs += [robot(str(scenario), a, port, tmp_path / f"{a}.err") for a in ("left", "right")]
        page = open_page(url, view=None)
        page.evaluate("window.__marker = 'not reloaded'")
        page.wait_for_selector("#turn[data-turn='yours']", timeout=60_000)
        first = page.locator("#step-action").inner_text()
        assert first.startswith("pick_up(human, ")
        page.locator("#op-done").click()
        page.wait_for_selector(f"#step-action:not(:has-text('{first}'))", timeout=30_000)
        wait_until(store, lambda r: any(k == "human_action" for _, _, k, _ in r), 30)
        os.kill(manager.pid, signal.SIGKILL)
        manager.wait(10)
        page.wait_for_selector("#link.link-down", timeout=15_000)  # the page saw it go
        before = rows(store)
        assert not any(k == "outcome" for _, _, k, _ in before), "killed too late"
        # on the ports the first manager got: the arms keep dialling, the page reconnects
        resumed = cell(str(scenario), port, store, "--resume", "--web", f"127.0.0.1:{web}",
                       log=tmp_path / "cell2.err")  # fmt: skip
        procs.append(resumed)
        page.wait_for_selector("#link.link-up", timeout=60_000)
        page.wait_for_selector("#turn[data-turn='yours']", timeout=60_000)
        second = page.locator("#step-action").inner_text()
        assert second.startswith("screw(human, ")  # the step after the stored one
        page.locator("#op-done").click()
        page.wait_for_selector("#outcome[data-outcome='solved']", timeout=60_000)
        assert page.evaluate("window.__marker") == "not reloaded"
        data = finish(resumed)
    finally:
        kill_all(procs)
    assert data["outcome"] == "solved", (tmp_path / "cell2.err").read_text()[-2000:]
    done = [b["action"] for _, _, k, b in rows(store) if k == "human_action"]
    assert done == [first, second]  # each of the person's steps once, across the crash
