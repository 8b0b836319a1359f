"""The panel's backend over the live cell (in one process: in-process bus, arms inside, the
operator only at the panel; the cell's loop on its own thread as under `flexhrc cell`)."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from flexhrc.cell import Cell, EventStore, RobotAgent, summarise_store
from flexhrc.scenario import load_scenario
from flexhrc.taskmanager.simulator import AnalyticSimulator
from flexhrc.transport import InProcessBus
from flexhrc.web import PanelInputError
from flexhrc.web.live import CellPanel
from tests.web.helpers import until


class Running:
    def __init__(self, tmp: Path, text: str, realtime: float = 0.0):
        path = tmp / "scenario.yaml"
        path.write_text(text)
        scenario = load_scenario(str(path))
        bus = InProcessBus()
        self.store_path = tmp / "cell.db"
        self.store = EventStore(self.store_path)
        self.cell = Cell(
            scenario,
            bus,
            store=self.store,
            realtime=realtime,
            ordered=True,
            agent_speed=0.0,
            simulator=AnalyticSimulator(),
            liveliness=False,
        )
        arms = [
            RobotAgent(a.name, scenario, bus, execution=AnalyticSimulator())
            for a in scenario.domain.agents.values()
            if not a.is_human
        ]
        self.panel = CellPanel(self.cell)
        self.summary: dict[str, Any] = {}

        def pump(timeout: float) -> None:
            bus.flush()
            for arm in arms:
                arm.poll()
            self.panel.poll()
            time.sleep(0.002)  # paces the loop (the arms answer on their next poll)

        self.thread = threading.Thread(
            target=lambda: self.summary.update(self.cell.run(pump=pump, max_wall_s=60)),
            daemon=True,
        )
        self.thread.start()

    def until(self, check: Any, timeout: float = 20.0) -> dict[str, Any]:
        """The first snapshot for which ``check`` holds (woken by the panel's change
        notifications, not a sleep)."""
        return until(self.panel, check, timeout)


@pytest.fixture
def running(tmp_path: Path) -> Iterator[Any]:
    started: list[Running] = []

    def make(text: str, realtime: float = 0.0) -> Running:
        r = Running(tmp_path, text, realtime)
        started.append(r)
        return r

    yield make
    for r in started:
        r.thread.join(30)
        r.panel.close()
        r.cell.close()
        r.store.close()


def _asked(snap: dict[str, Any]) -> list[str]:
    return [s["next"] for s in snap["suggestions"] if s["owner"] == "human" and s["next"]]


def test_the_operator_at_the_panel_completes_the_cell(running: Any) -> None:
    r = running("scenario: table_assembly\nunreachable_bolts: [2]\n")
    snap = r.until(lambda s: bool(_asked(s)) and (s["waiting"] or "").startswith("waiting for"))
    assert {"outcome", "suggestions", "agents", "events"} <= set(snap)
    events = snap["events"]
    for bad, status in [
        ({"action": "fly(human, leg1)"}, 404),
        ({"action": "pick_up(human, nothing)"}, 404),
        ({"action": "pick_up(human)"}, 400),
        ({"action": "grasp(left, leg1)"}, 409),
        ({"action": "screw(human, leg1, bolt_4)"}, 409),  # advances nothing now
        ({"take": "no_such_arc"}, 404),
        ({"take": "connected_1"}, 400),
    ]:
        with pytest.raises(PanelInputError) as err:
            r.panel.submit(bad)
        assert err.value.status == status, bad
    assert len(r.cell.events) == events  # nothing stored, nothing changed
    for _ in range(2):
        (nxt,) = _asked(r.panel.snapshot())
        assert r.panel.submit({"action": nxt})["action"] == nxt
        r.until(lambda s, nxt=nxt: nxt not in _asked(s))
    r.thread.join(30)
    r.panel.close()  # as `flexhrc cell` does when the loop ends: the last state goes out
    assert r.summary["outcome"] == "solved"
    assert r.summary["human_actions"] == 2
    human = [ev.body["action"] for ev in r.cell.events if ev.kind == "human_action"]
    assert [a.split("(")[0] for a in human] == ["pick_up", "screw"]
    final = r.panel.snapshot()
    assert final["outcome"] == "solved" and final["waiting"] is None
    assert any(t["agents"] == ["human"] for t in final["timeline"])


def test_take_and_stop_in_the_cell(running: Any) -> None:
    r = running("scenario: table_assembly\n", realtime=20.0)
    r.until(lambda s: any(a["status"] == "busy" for a in s["agents"]))
    snap = r.panel.snapshot()
    assert "human_1" in snap["takeable"]
    result = r.panel.submit({"take": "human_1"})
    assert result["actions"][0].startswith("pick_up(human, ")
    kinds = [ev.kind for ev in r.cell.events]
    assert "human_take" in kinds
    snap = r.until(lambda s: bool(_asked(s)))
    owners = {s["element"]: s["owner"] for s in snap["suggestions"]}
    assert owners.get("human_1") == "human" and owners.get("robot_1") is None
    # stop an arm: stored as an input, the arm is out of use until resumed
    arm = "right"
    r.panel.stop_robot(arm)
    snap = r.panel.snapshot()
    assert next(a for a in snap["agents"] if a["name"] == arm)["status"] == "stopped"
    with pytest.raises(PanelInputError):
        r.panel.stop_robot(arm)
    downs = [ev for ev in r.cell.events if ev.kind == "agent_down"]
    assert downs and downs[-1].body["by"] == "operator"
    # a panel on a resumed cell reads the operator's stops from the store (read here while the
    # ordered loop holds every answer until the operator, who was asked, has acted)
    assert CellPanel(r.cell).halted == {arm}
    r.panel.resume_robot(arm)
    for _ in range(2):
        (nxt,) = _asked(r.panel.snapshot())
        r.panel.submit({"action": nxt})
        r.until(lambda s, nxt=nxt: nxt not in _asked(s) or s["outcome"] != "running")
    r.thread.join(30)
    assert r.summary["outcome"] == "solved"
    assert r.summary["legs_by_agent"]["human"] == 1
    # the store with the operator's take and stop still replays (`flexhrc replay FILE.db`)
    summary, _ = summarise_store(r.store_path)
    assert summary["outcome"] == "solved"
