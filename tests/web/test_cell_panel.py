"""Acceptance: the table assembly completed with a person taking part only through the panel
(the test clicks in headless chromium), the manager and the arms as separate processes over
Zenoh on 127.0.0.1 (multicast scouting off, ports the cell binds itself and reports)."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("zenoh")
pytest.importorskip("uvicorn")
pytest.importorskip("playwright")

from playwright.sync_api import TimeoutError as PlaywrightTimeout

from tests.cell.helpers import listening_port
from tests.conftest import subprocess_env

pytestmark = pytest.mark.slow

# no arm reaches bolt 2: an arm brings a leg to the middle pose, the operator screws it
SCENARIO = "scenario: table_assembly\nunreachable_bolts: [2]\n"


def _flexhrc(*args: str, log: Path) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "flexhrc", *args],
        stdout=subprocess.PIPE,
        stderr=log.open("w"),
        text=True,
        env=subprocess_env(),
    )


def test_operator_only_at_the_panel_with_manager_and_arms_as_processes(
    tmp_path: Path, open_page: Any
) -> None:
    scenario = tmp_path / "table.yaml"
    scenario.write_text(SCENARIO)
    cell_log, ready = tmp_path / "cell.err", tmp_path / "cell.ready"
    # the manager with the panel first, on ports it binds itself (it reports them), then the
    # arms; no operator process: the person at the page is the operator
    procs = [
        _flexhrc(
            "cell", str(scenario), "--transport", "zenoh", "--agents", "external",
            "--listen", "tcp/127.0.0.1:0", "--ready-file", str(ready),
            "--store", str(tmp_path / "cell.db"), "--wait", "30",
            "--web", "127.0.0.1:0", "--json", log=cell_log,
        ),
    ]  # fmt: skip
    try:
        endpoint = f"tcp/127.0.0.1:{listening_port(ready, procs[0])}"
        procs += [
            _flexhrc("agent", "robot", str(scenario), "--arm", arm, "--connect", endpoint,
                     log=tmp_path / f"{arm}.err")
            for arm in ("left", "right")
        ]  # fmt: skip
        # the ready file says where the panel listens too (--web 127.0.0.1:0: as bound)
        url = json.loads(ready.read_text())["web"]
        assert re.fullmatch(r"http://127\.0\.0\.1:\d+/", url) and not url.endswith(":0/")
        page = open_page(url)
        page.evaluate("window.__marker = 'not reloaded'")
        clicked: list[str] = []
        banners: list[str] = []
        deadline = time.monotonic() + 60
        while (
            time.monotonic() < deadline
            and not page.locator("#outcome[data-outcome='solved']").count()
        ):
            # what the page asks the operator now, read at once (the page may redraw any time)
            action, banner = page.evaluate(
                "[document.querySelector('#suggestions tr.mine button.done')?.dataset.action"
                " ?? null, document.getElementById('banner').textContent]"
            )
            if action and action not in clicked:
                try:
                    page.click(f"#suggestions button.done[data-action='{action}']", timeout=2_000)
                except PlaywrightTimeout:
                    continue  # gone meanwhile; look again
                clicked.append(action)
                banners.append(banner)
            page.wait_for_timeout(50)
        page.wait_for_selector("#outcome[data-outcome='solved']", timeout=5_000)
        assert page.evaluate("window.__marker") == "not reloaded"
        out, _ = procs[0].communicate(timeout=30)
        for p in procs[1:]:
            assert p.wait(15) == 0
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
            p.wait(10)
    assert procs[0].returncode == 0, cell_log.read_text()[-2000:]
    data = json.loads(out)
    assert data["outcome"] == "solved"
    assert [a.split("(")[0] for a in clicked] == ["pick_up", "screw"]
    # the page said what the cell was waiting for
    assert all(b.startswith("waiting for the operator") for b in banners), banners
    assert data["human_actions"] == 2  # the two clicks, stored as the operator's actions
    assert data["legs_by_agent"]["human"] == 1
    assert data["legs_by_agent"]["left"] + data["legs_by_agent"]["right"] == 3
