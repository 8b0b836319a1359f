"""`flexhrc cell` and `flexhrc agent` as functions: `serve_cell(CellConfig)`, `join_cell(AgentConfig)`."""

from __future__ import annotations

import json
import threading
from pathlib import Path
from typing import Any

import pytest

from flexhrc.cell import AgentConfig, CellConfig, join_cell, serve_cell
from flexhrc.cell.serve import summary_line, trace_line
from flexhrc.errors import FlexhrcError
from flexhrc.scenario import load_scenario

from .test_cell_inprocess import run_cli


@pytest.mark.parametrize(
    ("name", "seed", "human"),
    [("table_assembly", 0, "passive"), ("kitchen_drawer", 3, "takeover")],
)
def test_serve_cell_is_the_command(name: str, seed: int, human: str) -> None:
    """The same cooperation as `flexhrc cell NAME --seed S --human P --json`."""
    traced = []

    def trace(ev: dict[str, Any]) -> None:
        line = trace_line(ev)
        if line:
            traced.append(line)

    data = serve_cell(
        load_scenario(name, seed=seed), CellConfig(seed=seed, human=human), trace=trace
    )
    res = run_cli("cell", name, "--seed", str(seed), "--human", human, "--json", "--quiet")
    assert res.returncode == (0 if data["outcome"] == "solved" else 1), res.stderr
    cli = json.loads(res.stdout)
    assert data["outcome"] == cli["outcome"] == "solved"
    assert data["by_agent"] == cli["by_agent"]
    assert data["solved_hyperarcs"] == cli["solved_hyperarcs"]
    assert set(data) == set(cli)
    assert traced[-1].endswith("outcome: SOLVED")
    assert summary_line(data).startswith("outcome solved; ")


def test_serve_cell_polls_and_closes_what_is_attached(tmp_path: Path) -> None:
    class Watcher:
        def __init__(self, cell: Any) -> None:
            self.cell, self.polls, self.closed = cell, 0, False

        def poll(self) -> None:
            self.polls += 1

        def close(self) -> None:
            self.closed = True

    made: list[Watcher] = []
    store = tmp_path / "cell.db"
    ready = tmp_path / "ready.json"
    data = serve_cell(
        load_scenario("table_assembly", segments="legs"),
        CellConfig(store=store, ready_file=ready),
        attach=[lambda cell: made.append(Watcher(cell)) or made[-1]],
    )
    assert data["outcome"] == "solved"
    (watcher,) = made
    assert watcher.polls > 0 and watcher.closed and watcher.cell.tm.outcome == "solved"
    assert json.loads(ready.read_text())["listen"] == []  # in-process: nothing to connect to
    assert f"in {store}" in summary_line(data, store)
    from flexhrc.cell.store import read_store

    assert [ev.kind for ev in read_store(store)][-2:] == ["outcome", "summary"]


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"wait": 0}, "--wait must be a positive number of seconds, got 0"),
        ({"wait": float("nan")}, "--wait must be a positive number of seconds"),
        ({"realtime": -1.0}, "--realtime must be a finite number >= 0, got -1.0"),
        ({"realtime": float("inf")}, "--realtime must be a finite number >= 0"),
        ({"agents": "external"}, "--agents external needs --transport zenoh"),
        ({"connect": ("tcp/127.0.0.1:1",)}, "--listen and --connect go with --transport zenoh"),
        ({"resume": True}, "--resume needs --store FILE.db"),
        ({"transport": "zenoh", "agents": "external", "human": "takeover"},
         "--human goes with --agents internal"),
        ({"human": "lazy"}, "--human 'lazy': choose one of passive, takeover"),
        ({"transport": "carrier pigeon"}, "--transport 'carrier pigeon': choose one of"),
        ({"simulator": "exact"}, "--simulator 'exact': choose one of auto, analytic, kinematic"),
        ({"transport": "zenoh", "cell": "a/b"}, "--cell 'a/b': letters, digits"),
    ],
)  # fmt: skip
def test_cell_config_refuses_bad_options_naming_them(options: dict[str, Any], message: str) -> None:
    with pytest.raises(FlexhrcError) as err:
        CellConfig(**options)
    assert message in str(err.value)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"kind": "robot", "name": "left"}, "--connect ENDPOINT is needed"),
        ({"kind": "drone", "name": "x", "connect": ("tcp/127.0.0.1:1",)}, "KIND 'drone'"),
        ({"kind": "robot", "name": "left", "connect": ("tcp/127.0.0.1:1",), "cell": "a b"},
         "--cell 'a b': letters, digits"),
    ],
)  # fmt: skip
def test_agent_config_refuses_bad_options_naming_them(
    options: dict[str, Any], message: str
) -> None:
    with pytest.raises(FlexhrcError) as err:
        AgentConfig(**options)
    assert message in str(err.value)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"kind": "robot", "name": "middle"}, "--arm 'middle': no robot agent"),
        ({"kind": "human", "name": "left"}, "--name 'left': no human agent"),
        ({"kind": "human", "name": "human", "profile": "lazy"},
         "--profile 'lazy': unknown operator profile"),
    ],
)  # fmt: skip
def test_join_cell_checks_the_names_before_the_network(
    options: dict[str, Any], message: str
) -> None:
    config = AgentConfig(connect=("tcp/127.0.0.1:1",), **options)
    with pytest.raises(FlexhrcError) as err:
        join_cell(load_scenario("table_assembly"), config)
    assert message in str(err.value)


def test_a_cell_and_its_agents_over_zenoh_in_one_script(tmp_path: Path) -> None:
    """What `flexhrc cell --transport zenoh --agents external` and three `flexhrc agent`
    processes do, from Python: the same cooperation as the cell with its agents inside."""
    pytest.importorskip("zenoh")
    scenario = load_scenario("table_assembly", segments="legs")
    ready = tmp_path / "ready.json"
    config = CellConfig(
        transport="zenoh", agents="external", listen=("tcp/127.0.0.1:0",), ready_file=ready
    )
    out: dict[str, Any] = {}

    def cell() -> None:
        out["cell"] = serve_cell(scenario, config)

    thread = threading.Thread(target=cell, daemon=True)
    thread.start()
    while not ready.exists() and thread.is_alive():
        thread.join(0.01)
    endpoint = json.loads(ready.read_text())["listen"][0]
    agents = [
        threading.Thread(
            target=lambda k=kind, n=name: out.__setitem__(
                n, join_cell(load_scenario("table_assembly", segments="legs"),
                             AgentConfig(kind=k, name=n, connect=(endpoint,)))
            ),
            daemon=True,
        )
        for kind, name in [("robot", "left"), ("robot", "right"), ("human", "human")]
    ]  # fmt: skip
    for t in agents:
        t.start()
    for t in [thread, *agents]:
        t.join(120)
    inside = serve_cell(scenario, CellConfig())
    assert out["cell"]["outcome"] == inside["outcome"] == "solved"
    assert out["cell"]["by_agent"] == inside["by_agent"]
    assert {out[n]["outcome"] for n in ("left", "right", "human")} == {"solved"}
    executed = out["left"]["executed"] + out["right"]["executed"]
    assert len(executed) == len(set(executed)) == out["cell"]["robot_actions"]
