"""The embedded default cell: one process, in-process bus, agents inside."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from flexhrc.cell import Cell, HumanAgent, RobotAgent
from flexhrc.cell.components import execution_model
from flexhrc.scenario import load_scenario
from flexhrc.transport import InProcessBus

from ..conftest import subprocess_env
from .helpers import Crash, pump_of, simulated_agents


def run_cli(*args: str, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "flexhrc", *args],
        capture_output=True,
        text=True,
        env=subprocess_env(),
        timeout=timeout,
    )


def _cell(scenario: Any) -> tuple[Cell, list[Any], InProcessBus]:
    bus = InProcessBus()
    cell = Cell(scenario, bus, liveliness=False, simulator=execution_model("analytic"))
    agents: list[Any] = []
    for a in scenario.domain.agents.values():
        cls = HumanAgent if a.is_human else RobotAgent
        agents.append(cls(a.name, scenario, bus, execution=execution_model("analytic")))
    return cell, agents, bus


def test_snapshot_is_json_and_human_input_drives_the_manager() -> None:
    from flexhrc.scenario.builtin.table import table_assembly

    scenario = table_assembly(segments="legs")  # the legs fix: bolt 1 is the first step
    cell, agents, bus = _cell(scenario)
    snaps: list[dict[str, Any]] = []
    told = []

    def pump(timeout: float) -> None:
        bus.flush()
        for a in agents:
            a.poll()
        if not told:  # an operator at a panel: "I took leg2 and screwed it to bolt 1"
            cell.human_input("pick_up(human, leg2)")
            cell.human_input("screw(human, leg2, bolt_1)")
            told.append(True)
        snaps.append(json.loads(json.dumps(cell.snapshot())))

    data = cell.run(pump=pump)
    assert data["outcome"] == "solved"
    assert data["fixed_by_agent"]["human"] == 1
    assert data["solved_hyperarcs"][0]["hyperarc"] == "human_1"
    snap = snaps[-1]
    assert {"outcome", "agents", "suggestions", "events_stored", "timeline", "knowledge"} <= set(
        snap
    )
    assert set(snap["agents"]) == {"human", "left", "right"}
    assert all({"alive", "available", "status"} <= set(a) for a in snap["agents"].values())
    assert json.loads(json.dumps(cell.snapshot()))["outcome"] == "solved"


def test_parallel_scenario_uses_every_arm() -> None:
    scenario = load_scenario("parallel_assembly")
    cell, agents, bus = _cell(scenario)
    data = cell.run(pump=pump_of(cell, bus, agents))
    assert data["outcome"] == "solved"
    arms = [a for a in data["fixed_by_agent"] if a.startswith("arm")]
    assert len(arms) == 6 and all(data["fixed_by_agent"][a] >= 1 for a in arms)
    assert sum(data["fixed_by_agent"].values()) == 12


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["cell", "table", "--agents", "external"], "--agents external needs --transport zenoh"),
        (["cell", "table", "--resume"], "--resume needs --store"),
        (["cell", "no_such_scenario"], "unknown scenario 'no_such_scenario'"),
        (["cell", "table", "--realtime", "-1"], "--realtime must be"),
        (["cell", "table", "--realtime", "nan"], "--realtime must be"),
        (["cell", "table", "--connect", "tcp/127.0.0.1:1"], "go with --transport zenoh"),
        (["cell", "table", "--store", "/no/such/dir/x.db"], "does not exist"),
        (["cell", "table", "--transport", "zenoh", "--listen", "nonsense"], "tcp/HOST:PORT"),
        (["agent", "robot", "table", "--arm", "middle", "--connect", "tcp/127.0.0.1:1"],
         "--arm 'middle': no robot agent"),
        (["agent", "human", "table", "--name", "left", "--connect", "tcp/127.0.0.1:1"],
         "--name 'left': no human agent"),
        (["agent", "human", "table", "--name", "human", "--profile", "lazy",
          "--connect", "tcp/127.0.0.1:1"], "--profile 'lazy': unknown operator profile"),
        (["agent", "robot", "table", "--arm", "left"], "--connect ENDPOINT is needed"),
        (["cell", "table", "--transport", "zenoh", "--agents", "external", "--human", "takeover"],
         "--human goes with --agents internal"),
        (["cell", "table", "--human", "lazy"], "--human: invalid choice: 'lazy'"),
    ],
)  # fmt: skip
def test_bad_arguments_are_one_clear_error(args: list[str], message: str, tmp_path: Path) -> None:
    res = run_cli(*args, timeout=60)
    assert res.returncode == 2, res.stderr
    assert message in res.stderr
    assert "Traceback" not in res.stderr


def test_scenario_file_errors_name_the_file(tmp_path: Path) -> None:
    bad = tmp_path / "s.yaml"
    bad.write_text("scenario: table_assembly\nlegz: 3\n")
    res = run_cli("cell", str(bad))
    assert res.returncode == 2 and "s.yaml" in res.stderr and "legz" in res.stderr


@pytest.mark.parametrize("crash_after", [6, 33, 50])  # 33: the suggestion is open
def test_resume_in_one_process_ends_like_the_uninterrupted_run(
    tmp_path: Path, crash_after: int
) -> None:
    """The manager dies after `crash_after` stored events (one with the operator's suggestion
    open); a fresh cell resumes from the store and ends in the same state."""
    from flexhrc.cell import EventStore
    from flexhrc.cell.store import read_store
    from flexhrc.scenario.builtin.table import table_assembly

    scenario = table_assembly(segments="legs", unreachable_bolts=(2,))

    ref_cell, ref_agents, ref_bus = _cell(scenario)
    ref = ref_cell.run(pump=pump_of(ref_cell, ref_bus, ref_agents))
    assert ref["human_actions"] == 2

    path = tmp_path / "s.db"
    store = EventStore(path)
    bus = InProcessBus()
    cell = Cell(scenario, bus, store=store, liveliness=False, simulator=execution_model("analytic"))
    agents = simulated_agents(scenario, bus)
    with pytest.raises(Crash):
        cell.run(pump=pump_of(cell, bus, agents, crash_after))
    store.close()
    n = len(read_store(path))
    store = EventStore(path, resume=True)
    bus2 = InProcessBus()
    again = Cell(
        scenario,
        bus2,
        store=store,
        resume=True,
        liveliness=False,
        simulator=execution_model("analytic"),
    )
    # the agents are new processes too here: they execute what was outstanding
    agents2 = simulated_agents(scenario, bus2)
    data = again.run(pump=pump_of(again, bus2, agents2))
    store.close()
    assert data["outcome"] == "solved" and data["cell"]["resumed"]
    assert data["knowledge"] == ref["knowledge"]
    assert data["timing"]["total_s"] == ref["timing"]["total_s"]
    assert data["human_actions"] == ref["human_actions"]
    events = read_store(path)
    assert [e.seq for e in events] == list(range(1, len(events) + 1)) and len(events) > n
    ids = [e.body["id"] for e in events if e.kind == "command"]
    assert len(ids) == len(set(ids))


def test_a_lost_command_is_sent_again_and_executed_once() -> None:
    class LossyBus(InProcessBus):
        lost = 0

        def publish(self, topic: str, payload: Any) -> None:
            if topic == "cmd/left" and not self.lost:
                self.lost += 1  # the first command to the left arm never arrives
                return
            super().publish(topic, payload)

    scenario = load_scenario("table_assembly")
    bus = LossyBus()
    cell = Cell(scenario, bus, liveliness=False, simulator=execution_model("analytic"))
    agents = simulated_agents(scenario, bus)
    data = cell.run(pump=pump_of(cell, bus, agents))
    assert data["outcome"] == "solved" and bus.lost == 1
    assert data["cell"]["resent"] == 1
    executed = [i for a in agents if isinstance(a, RobotAgent) for i in a.executed]
    assert len(executed) == len(set(executed)) == data["robot_actions"]


def test_external_agents_that_never_come_and_a_taken_port_are_clear_errors(
    tmp_path: Path,
) -> None:
    pytest.importorskip("zenoh")
    from flexhrc.transport.zenoh import ZenohTransport, zenoh_config

    args = ["cell", "table_assembly", "--transport", "zenoh", "--listen"]
    ready = tmp_path / "cell.ready"
    res = run_cli(
        *args, "tcp/127.0.0.1:0", "--agents", "external", "--wait", "1", "--ready-file", str(ready)
    )
    assert res.returncode == 2 and "no agent process for human, left, right" in res.stderr
    assert "flexhrc agent robot|human" in res.stderr and "Traceback" not in res.stderr
    # the port the system gave it, in the ready file and on stderr
    got = json.loads(ready.read_text())
    assert got["cell"] == "default" and len(got["listen"]) == 1
    assert int(got["listen"][0].rsplit(":", 1)[1]) > 0
    assert f"listening on {got['listen'][0]}" in res.stderr
    bad = run_cli(*args, "tcp/127.0.0.1:0", "--ready-file", str(tmp_path / "no" / "r.json"))
    assert bad.returncode == 2 and "--ready-file" in bad.stderr and "Traceback" not in bad.stderr
    with ZenohTransport(zenoh_config(listen=["tcp/127.0.0.1:0"])) as holder:
        taken = holder.locators()[0]  # bound by this process for the whole call
        res = run_cli(*args, taken)
    assert res.returncode == 2 and "cannot open a Zenoh session" in res.stderr
    assert "Traceback" not in res.stderr


def test_percepts_are_inputs_stored_and_checked() -> None:
    from flexhrc.cell import protocol as P

    scenario = load_scenario("table_assembly")
    cell, agents, bus = _cell(scenario)
    sent: list[bool] = []

    def pump(timeout: float) -> None:
        if cell.started and not sent:  # a perception process reports a leg where it lies
            where = list(cell.kb.position("leg2"))
            good = P.message("percept", id="cam:1", object="leg2", object_type="leg", pose=where)
            bus.publish(P.PERCEPT_TOPIC, good)
            bus.publish(P.PERCEPT_TOPIC, good)  # the same percept twice
            bus.publish(P.PERCEPT_TOPIC, {**good, "id": "cam:2", "pose": [1, float("nan"), 0]})
            # an object the scenario's world does not know is not added: it is refused
            unknown = {**good, "id": "cam:3", "object": "box9", "object_type": "obstacle"}
            bus.publish(P.PERCEPT_TOPIC, unknown)
            sent.append(True)
        bus.flush()
        for a in agents:
            a.poll()

    data = cell.run(pump=pump)
    assert data["outcome"] == "solved"
    assert [e.body["object"] for e in cell.events if e.kind == "percept"] == ["leg2"]
    assert "box9" not in cell.kb.objects
    assert data["cell"]["dropped"] == 3
    assert any("duplicate percept" in d for d in cell.dropped)
    assert any("no object 'box9' in this cell's world" in d for d in cell.dropped)


class TokenBus(InProcessBus):
    """The in-process bus with liveliness tokens, delivered in order with the messages — and
    it loses the first ``operator`` message, as Zenoh drops a publication its session knows no
    subscriber for yet while the token that follows it arrives."""

    def __init__(self) -> None:
        super().__init__()
        self.tokens: set[str] = set()
        self.lost: list[Any] = []
        self._watches = 0

    def publish(self, topic: str, payload: Any) -> None:
        if isinstance(payload, dict) and payload.get("type") == "operator" and not self.lost:
            self.lost.append(payload)
            return
        super().publish(topic, payload)

    def declare_token(self, key: str) -> Any:
        from types import SimpleNamespace

        def undeclare() -> None:
            self.tokens.discard(key)
            InProcessBus.publish(self, "liveliness", (key, False))

        self.tokens.add(key)
        InProcessBus.publish(self, "liveliness", (key, True))
        return SimpleNamespace(undeclare=undeclare)

    def watch_liveliness(self, pattern: str, callback: Any, *, history: bool = True) -> Any:
        from fnmatch import fnmatchcase

        def relay(event: tuple[str, bool]) -> None:
            if fnmatchcase(event[0], pattern):
                callback(*event)

        self._watches += 1
        past = f"liveliness/history/{self._watches}"  # the tokens already there: to it alone
        self.subscribe(past, relay)
        for key in sorted(self.tokens) if history else ():
            InProcessBus.publish(self, past, (key, True))
        return self.subscribe("liveliness", relay)

    def wait(self, timeout: float) -> None:
        """Nothing arrives from elsewhere: the next flush delivers what is queued."""


@pytest.mark.parametrize("manager_first", [True, False])
def test_a_lost_operator_announcement_never_starts_the_cell_without_the_profile(
    manager_first: bool,
) -> None:
    """The operator's token waits for the manager's acknowledgement of its profile (a
    ``state`` that shows it): the first announcement is lost, the manager still starts with
    it — whether the manager or the operator came up first."""
    scenario = load_scenario("table_assembly")
    bus = TokenBus()
    analytic = execution_model("analytic")

    def make_agents() -> list[Any]:
        return [
            HumanAgent(a.name, scenario, bus, profile="takeover", execution=analytic)
            if a.is_human
            else RobotAgent(a.name, scenario, bus, execution=analytic)
            for a in scenario.domain.agents.values()
        ]

    if manager_first:
        cell = Cell(scenario, bus, simulator=analytic)
        agents = make_agents()
    else:
        agents = make_agents()
        cell = Cell(scenario, bus, simulator=analytic)
    data = cell.run(pump=pump_of(cell, bus, agents))
    assert [m["agent"] for m in bus.lost] == ["human"]  # the first announcement never arrived
    assert cell.events[0].kind == "start"
    assert cell.events[0].body["operators"] == {"human": "takeover"}
    assert data["outcome"] == "solved"
    assert sum(e.kind == "human_decides" for e in cell.events) == 4  # it took over the legs
