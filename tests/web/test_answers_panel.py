"""The person's answers at the panel (issue 22, item 1): ``POST /api/human`` with
``{"reply": "decline" | "cannot" | "start" | "give_back"}``, and a "done" that carries its start,
so that ``replay`` and the timeline's human lane show the person's time."""

from __future__ import annotations

from typing import Any

import pytest

from flexhrc.cell.replay import replay
from flexhrc.cell.store import read_store
from flexhrc.web import PanelInputError
from flexhrc.web.backend import parse_human_body
from tests.cell.test_answers import LIDS
from tests.web.helpers import press_done, until


def _asked(snap: dict[str, Any]) -> list[str]:
    return [s["next"] for s in snap["suggestions"] if s["owner"] == "human" and s["next"]]


def _ended(snap: dict[str, Any]) -> bool:
    return snap["outcome"] != "running"


@pytest.mark.parametrize("reply", ["decline", "cannot", "give_back"])
def test_a_step_the_person_answers_so_is_done_by_the_arm(local_panel: Any, reply: str) -> None:
    panel = local_panel(LIDS)
    assert _asked(until(panel, lambda s: bool(_asked(s)))) == ["carry(human, lid_a, box)"]
    body = {"reply": reply, **({"reason": "no gloves"} if reply == "cannot" else {})}
    answer = panel.submit(body)
    assert answer["ok"] and answer["reply"] == reply
    assert panel.wait(30)
    snap = until(panel, _ended)
    assert snap["outcome"] == "solved", snap["reason"]
    [said] = [e.body for e in panel.cell.events if e.kind == "human_declined"]
    assert said["reply"] == reply and said["element"] == "place_a"
    if reply == "cannot":
        assert said["reason"] == "no gloves"
        assert (
            "place_a"
            not in [e.body["element"] for e in panel.cell.events[1:] if e.kind == "suggestion"][1:]
        )
    lane = [t for t in snap["timeline"] if t["agents"] == ["arm"]]
    assert lane[0]["action"] == "carry(arm, lid_a, box)"


def test_start_then_done_gives_the_human_lane_its_time(local_panel: Any, tmp_path: Any) -> None:
    store = tmp_path / "panel.db"
    panel = local_panel(LIDS, store=store)
    for _ in range(2):  # both lids, by the person
        snap = until(panel, lambda s: bool(_asked(s)) or _ended(s))
        (step,) = _asked(snap)
        assert panel.submit({"reply": "start"})["reply"] == "start"
        press_done(panel, step)
    assert panel.wait(30)
    assert until(panel, _ended)["outcome"] == "solved"
    panel.close()
    events = read_store(store)
    starts = [e.t for e in events if e.kind == "human_reply" and e.body["reply"] == "start"]
    reports = [e for e in events if e.kind == "human_action"]
    # every "done" carries the start the person said (the panel's done had none: 0.00 s)
    assert [r.body["start"] for r in reports] == [round(t, 6) for t in starts]
    assert all(r.body["start"] < r.t for r in reports)
    report = replay(store)
    assert report.json["timing"]["human_actions_s"] > 0
    lane = [e for e in report.events if e["type"] == "action_end" and e["agents"] == ["human"]]
    assert len(lane) == 2 and all(e["t"] > e["start"] for e in lane)


def test_a_done_without_start_starts_when_the_step_was_put_to_the_person(
    local_panel: Any,
) -> None:
    panel = local_panel(LIDS)
    (step,) = _asked(until(panel, lambda s: bool(_asked(s))))
    press_done(panel, step)
    [report] = [e for e in panel.cell.events if e.kind == "human_action"][:1]
    [asked] = [e for e in panel.cell.events if e.kind == "suggestion"][:1]
    assert report.body["start"] == round(asked.t, 6) < report.t


def test_a_reply_with_nothing_asked_or_a_bad_body_is_refused() -> None:
    assert parse_human_body(b'{"reply": "cannot", "reason": "no tool"}') == {
        "reply": "cannot",
        "reason": "no tool",
    }
    for bad in (b'{"reply": "maybe"}', b'{"reason": "x"}', b'{"reply": "decline", "take": "a"}'):
        with pytest.raises(PanelInputError) as exc:
            parse_human_body(bad)
        assert exc.value.status == 400


def test_a_decline_after_the_end_is_refused(local_panel: Any) -> None:
    panel = local_panel(LIDS)
    (step,) = _asked(until(panel, lambda s: bool(_asked(s))))
    press_done(panel, step)
    press_done(panel, _asked(until(panel, lambda s: bool(_asked(s))))[0])
    until(panel, _ended)
    with pytest.raises(PanelInputError) as exc:
        panel.submit({"reply": "decline"})
    assert exc.value.status == 409
