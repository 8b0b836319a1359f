"""The operator's view of the panel (issue 24, item 1) in headless Chromium: the step the person
is asked, in plain words, with big buttons; what each arm does and will do; progress and a clock
that runs while the cell waits; banners in their colours and every control disabled at the end.
The page is opened as a person gets it (``view=None``: the operator's view is the default)."""

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

LID_WORDS = LIDS.replace(
    '      parameters: {"?who": agent, "?l": lid, "?to": container}\n',
    '      parameters: {"?who": agent, "?l": lid, "?to": container}\n'
    '      text: "Put {?l} on the {?to}"\n',
)


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


@pytest.fixture
def lids(tmp_path: Path) -> str:
    path = tmp_path / "lids.yaml"
    path.write_text(LID_WORDS)
    return str(path)


def test_the_operator_view_is_the_default_and_the_engineer_view_a_tab(
    serve: Any, open_page: Any, lids: str
) -> None:
    page = open_page(serve(lids, speed=5).url, view=None)
    assert page.locator("#operator").is_visible()
    assert not page.locator("#engineer").is_visible()
    page.locator("#tab-engineer").click()
    assert page.locator("#engineer").is_visible() and not page.locator("#operator").is_visible()
    assert page.locator("#tab-engineer").get_attribute("aria-selected") == "true"
    page.locator("#tab-engineer").press("ArrowLeft")  # keyboard: back to the operator's tab
    assert page.locator("#operator").is_visible()


def test_the_card_says_the_step_in_the_scenarios_words_and_done_advances(
    serve: Any, open_page: Any, lids: str
) -> None:
    coop = serve(lids, speed=5)
    page = open_page(coop.url, view=None)
    page.wait_for_selector("#turn[data-turn='yours']")
    assert page.locator("#turn-title").inner_text() == "Your turn"
    assert page.locator("#step-text").inner_text() == "Put lid a on the box"
    page.locator("#op-start").click()
    page.wait_for_selector('#message:has-text("you said I\'m starting")')
    page.locator("#op-done").click()
    page.wait_for_selector("#step-text:has-text('Put lid b on the box')")
    page.wait_for_selector("#op-progress-text:has-text('1 of 2 steps done')")
    page.locator("#op-decline").click()  # not now: the arm carries the second lid
    page.wait_for_selector("#banner.solved:has-text('solved')", timeout=20_000)
    events = coop.cell.events
    assert [e.body["element"] for e in events if e.kind == "human_declined"] == ["place_b"]
    assert [e.body["action"] for e in events if e.kind == "human_action"] == [
        "carry(human, lid_a, box)"
    ]
    # the end: a green banner, the card says so, and nothing can be pressed any more
    assert page.locator("#turn-title").inner_text() == "All done"
    assert page.locator("#op-progress-text").inner_text() == "2 steps done"
    assert page.locator(".operator button:enabled, main button:enabled").count() == 0
    assert page.locator("#op-robots button.stop").is_disabled()
    colour = page.eval_on_selector("#banner", "e => getComputedStyle(e).backgroundColor")
    assert colour == "rgb(227, 244, 234)"  # the success colour, not the waiting yellow


@pytest.mark.parametrize(
    ("button", "reply"), [("#op-cannot", "cannot"), ("#op-give-back", "give_back")]
)
def test_i_cannot_and_give_back_from_the_card(
    serve: Any, open_page: Any, lids: str, button: str, reply: str
) -> None:
    coop = serve(lids, speed=5)
    page = open_page(coop.url, view=None)
    page.wait_for_selector("#turn[data-turn='yours']")
    assert page.locator("#step-text").inner_text() == "Put lid a on the box"
    page.locator(button).click()
    page.wait_for_selector("#outcome[data-outcome='solved']", timeout=20_000)
    said = [
        (e.body["element"], e.body["reply"]) for e in coop.cell.events if e.kind == "human_declined"
    ]
    assert said == [("place_a", reply)]
    lane = [t["action"] for t in coop.snapshot()["timeline"] if t["agents"] == ["arm"]]
    assert lane[0] == "carry(arm, lid_a, box)"


def test_the_arms_say_what_they_do_and_will_do_and_an_offer_is_taken(
    serve: Any, open_page: Any
) -> None:
    coop = serve(table_legs(4), speed=1.5)  # slow arms: each step is on the page a while
    page = open_page(coop.url, view=None)
    now = page.locator("#op-robots li[data-status='busy'] .now").first
    now.wait_for()
    assert now.inner_text().startswith("now: ")
    words = now.inner_text()[5:]
    assert "(" not in words and "_" not in words  # plain words, not ground actions
    page.wait_for_selector("#op-robots li .next:has-text('next: ')")
    offer = page.locator("#op-take button[data-take='human_1']")
    assert offer.inner_text().startswith("I'll do this: Pick up leg")
    offer.click()
    page.wait_for_selector("#turn[data-turn='yours']")
    assert page.locator("#step-text").inner_text().startswith("Pick up leg")


def test_the_clock_runs_while_the_cell_waits_for_the_person(
    serve: Any, open_page: Any, lids: str
) -> None:
    coop = serve(lids, speed=5)
    page = open_page(coop.url, view=None)
    page.wait_for_selector("#turn[data-turn='yours']")
    frozen = page.evaluate("window.__panel.state.time")
    events = page.evaluate("window.__panel.events")
    # no event arrives while the person thinks, yet the clock goes on (at the cell's pace)
    deadline = time.monotonic() + 30  # the bound of a wait, not a timing assertion
    while page.evaluate("window.__panel.clock") <= frozen + 2:  # (the page's CSP forbids eval)
        assert time.monotonic() < deadline, "the clock stood still"
        page.wait_for_timeout(100)
    assert page.evaluate("window.__panel.events") == events
    shown = page.locator("#op-clock").inner_text()
    minutes, seconds = shown.split(":")
    assert int(minutes) * 60 + int(seconds) >= int(frozen + 2)


def test_a_tablet_sees_the_card_first(serve: Any, open_page: Any, lids: str) -> None:
    page = open_page(serve(lids, speed=5).url, view=None, width=1024)
    page.wait_for_selector("#turn[data-turn='yours']")
    box = page.locator("#op-done").bounding_box()
    assert box is not None and box["height"] >= 44 and box["width"] >= 44  # a touch target
    assert box["y"] + box["height"] <= 900  # above the fold
