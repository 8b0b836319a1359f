"""Fixtures of the panel's browser tests: Debian's chromium driven by Playwright.

Playwright's own browser download is never used (``executable_path`` points at the system
chromium that ``scripts/setup.sh`` installs); without chromium or Playwright the browser tests
skip with the reason.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from typing import Any

import pytest

CHROMIUM = os.environ.get("FLEXHRC_CHROMIUM") or shutil.which("chromium") or "/usr/bin/chromium"


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    sync_api = pytest.importorskip("playwright.sync_api")
    if not os.path.exists(CHROMIUM):
        pytest.skip(f"no chromium at {CHROMIUM} (apt-get install chromium; scripts/setup.sh does)")
    with sync_api.sync_playwright() as pw:
        b = pw.chromium.launch(
            executable_path=CHROMIUM,
            headless=True,
            args=["--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage"],
            timeout=30_000,
        )
        try:
            yield b
        finally:
            b.close()


@pytest.fixture
def open_page(browser: Any) -> Iterator[Any]:
    """``open_page(url, view=..., width=...)`` -> a new page in its own context, with JS errors
    collected. ``view="engineer"`` (the default here: most tests drive the graph and tables)
    opens the engineer's view; ``view=None`` the page as a person gets it (the operator's)."""
    contexts: list[Any] = []
    errors: list[str] = []
    requests: list[str] = []

    def make(url: str, view: str | None = "engineer", width: int = 1280) -> Any:
        if view is not None:
            url += ("&" if "?" in url else "?") + f"view={view}"
        ctx = browser.new_context(viewport={"width": width, "height": 900})
        ctx.on("request", lambda r: requests.append(r.url))
        contexts.append(ctx)
        page = ctx.new_page()
        page.set_default_timeout(10_000)
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.on(  # the panel's own security policy must not block any of its own parts
            "console",
            lambda m: errors.append(m.text) if "Content Security Policy" in m.text else None,
        )
        page.goto(url)
        return page

    yield make
    for ctx in contexts:
        ctx.close()
    assert not errors, errors
    # offline: everything the page loaded came from the panel itself, on loopback
    assert requests and all(u.startswith("http://127.0.0.1:") for u in requests), requests


@pytest.fixture
def local_panel(tmp_path: Any) -> Iterator[Any]:
    """``local_panel(scenario_text_or_name, speed=..., start=True)`` -> a running
    :class:`flexhrc.web.local.LocalPanel` (analytic simulator), closed at the end."""
    from flexhrc.web.local import LocalPanel

    made: list[Any] = []

    def make(scenario: str, *, speed: float = 200.0, start: bool = True, **kw: Any) -> Any:
        if "\n" in scenario:  # the text of a scenario file
            path = tmp_path / f"scenario{len(made)}.yaml"
            path.write_text(scenario)
            scenario = str(path)
        kw.setdefault("simulator", "analytic")
        panel = LocalPanel(scenario, speed=speed, **kw)
        made.append(panel)
        return panel.start() if start else panel

    yield make
    for panel in made:
        panel.close()
