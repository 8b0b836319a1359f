"""The operator station as a station (issue 24, item 5): readable and keyboard-operable (axe-core,
vendored from npm for the tests, finds no serious or critical violation in either view), a reload
mid-run keeps the state, several viewers see the same cooperation."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("uvicorn")
pytest.importorskip("playwright")

from flexhrc.web.local import LocalPanel, PanelConfig, serve_panel, table_legs
from tests.cell.test_answers import LIDS

AXE = Path(__file__).parent / "vendor" / "axe-core" / "axe.min.js"


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


def _axe(page: Any) -> list[dict[str, Any]]:
    """axe-core's violations of impact serious or critical on the page as it is now (evaluated
    through the DevTools protocol: the page's own CSP still holds for the page itself)."""
    page.evaluate(AXE.read_text())
    result = page.evaluate(
        "axe.run(document, {resultTypes: ['violations']})"
        ".then((r) => r.violations.map((v) => ({id: v.id, impact: v.impact, help: v.help,"
        " nodes: v.nodes.map((n) => n.target.join(' ')).slice(0, 5)})))"
    )
    return [v for v in result if v["impact"] in ("serious", "critical")]


@pytest.mark.parametrize("view", [None, "engineer"])
def test_no_serious_or_critical_accessibility_violation(
    serve: Any, open_page: Any, tmp_path: Path, view: str | None
) -> None:
    path = tmp_path / "lids.yaml"
    path.write_text(LIDS)
    page = open_page(serve(str(path), speed=5).url, view=view)
    page.wait_for_selector("#turn[data-turn='yours']", state="attached")
    page.wait_for_selector("#link.link-up")
    assert _axe(page) == []


def test_the_buttons_work_from_the_keyboard(serve: Any, open_page: Any, tmp_path: Path) -> None:
    path = tmp_path / "lids.yaml"
    path.write_text(LIDS)
    coop = serve(str(path), speed=5)
    page = open_page(coop.url, view=None)
    page.wait_for_selector("#turn[data-turn='yours']")
    page.locator("#op-done").focus()
    page.keyboard.press("Enter")
    page.wait_for_selector("#step-action:has-text('carry(human, lid_b, box)')")
    assert [e.body["action"] for e in coop.cell.events if e.kind == "human_action"] == [
        "carry(human, lid_a, box)"
    ]


def test_a_reload_mid_run_shows_the_same_state_and_two_viewers_agree(
    serve: Any, open_page: Any
) -> None:
    coop = serve(table_legs(4, unreachable_bolts=(1,)), speed=20)
    first = open_page(coop.url, view=None)
    second = open_page(coop.url, view=None)
    first.wait_for_selector("#turn[data-turn='yours']", timeout=30_000)
    step = first.locator("#step-action").inner_text()
    first.reload()
    first.wait_for_selector("#turn[data-turn='yours']")
    assert first.locator("#step-action").inner_text() == step
    second.wait_for_selector(f"#step-action:has-text('{step}')")
    assert (
        first.locator("#op-progress-text").inner_text()
        == second.locator("#op-progress-text").inner_text()
    )
