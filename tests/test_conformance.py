"""Conformance of every front end of the one cooperation engine (issue 19).

One parametrised test over (scenario x configuration). The scenarios: every shipped one
(:data:`flexhrc.scenario.SHIPPED`), the starter ``flexhrc scenario new`` writes, and every file
in ``examples/scenarios/`` (globbed at collection time, so a new example joins by itself). The
configurations drive the same loop, :class:`flexhrc.cell.Cell`, through different front ends:

* ``run`` — the reference, ``flexhrc.scenario.run(load(x), seed=S)`` in this process; the
  configuration checks ``flexhrc run --json --log`` and ``flexhrc replay`` of that log by it;
* ``cell`` — ``flexhrc cell X --json`` in a subprocess: the in-process bus, agents inside
  (seed 0 and a second seed; and ``cell-kinematic``, on the kinematic robot model);
* ``zenoh`` — the manager, one ``flexhrc agent robot`` per arm and one ``flexhrc agent human``
  per operator as separate processes over Zenoh on 127.0.0.1 (multicast scouting off); and
  ``zenoh-kinematic``, the manager and the arms on the kinematic robot model;
* ``ros2`` — ``flexhrc ros2 cell`` + ``flexhrc ros2 arm`` per arm + ``flexhrc ros2 human`` per
  operator, on a random ROS domain with localhost discovery; the arm nodes always execute on
  the kinematic robot model, so the manager simulates on it too and the reference is the run
  with ``simulator="kinematic"``;
* ``panel`` — ``flexhrc.web.serve_panel`` with the person in headless chromium clicking 'done'
  on whatever the page asks of them (collected only when the panel runs on the Cell, see
  :func:`_panel_on_the_cell`).

Every configuration on the simulated clock must give the reference's cooperation for the same
seed: outcome, the order and agents of ``solved_hyperarcs``, ``by_agent`` and the simulated
``timing.total_s``. The panel's clock is the wall clock (the person takes the time they take):
there the outcome and the report's keys must be the reference's. A difference is a bug of the
engine or of a front end, never a tolerance to widen: the known ones are in :data:`KNOWN`
(strict xfails, so a fix shows).
"""

from __future__ import annotations

import json
import os
import random
import shutil
import subprocess
import sys
import uuid
from functools import cache
from pathlib import Path
from typing import Any

import pytest

from flexhrc import scenario as sc

from .conftest import REPO, subprocess_env

EXAMPLES = sorted((REPO / "examples" / "scenarios").glob("*.yaml"))
# (id, what to load: a shipped name, a file, or "starter" for `flexhrc scenario new`)
SCENARIOS = (
    [(name, name) for name in sc.SHIPPED]
    + [("starter", "starter")]
    + [(f"examples/{p.stem}", str(p)) for p in EXAMPLES]
)
SEED = 0
SECOND_SEED = 3  # run vs cell only: the processes cost too much wall time for two seeds
TIMEOUT = 120.0  # wall seconds a process configuration may take on a busy machine


def _panel_on_the_cell() -> bool:
    """The panel runs on the one loop once :mod:`flexhrc.web` offers ``serve_panel`` (a
    :class:`flexhrc.cell.Cell` with the person at the page as its operator) for any scenario."""
    import flexhrc.web

    try:
        return callable(flexhrc.web.serve_panel)
    except AttributeError:
        return False


def _configurations() -> list[Any]:
    """(front end, seed, simulator) triples; simulator None is the scenario's own."""
    slow = pytest.mark.slow
    out: list[Any] = [
        pytest.param("run", SEED, None, id="run"),
        pytest.param("cell", SEED, None, id="cell", marks=slow),
        pytest.param("cell", SECOND_SEED, None, id=f"cell-seed{SECOND_SEED}", marks=slow),
        # the kinematic robot model keeps state (the arms' joints): one world or one per process
        pytest.param("cell", SEED, "kinematic", id="cell-kinematic", marks=slow),
        pytest.param("zenoh", SEED, None, id="zenoh", marks=slow),
        pytest.param("zenoh", SEED, "kinematic", id="zenoh-kinematic", marks=slow),
        # the ROS 2 arm nodes always execute on the kinematic robot model
        pytest.param("ros2", SEED, "kinematic", id="ros2", marks=slow),
    ]
    # PANEL: collected only when the panel runs on the Cell (branch `panel` of issue 19)
    if _panel_on_the_cell():
        out.append(pytest.param("panel", SEED, None, id="panel", marks=slow))
    return out


def _flexhrc(*args: str, env: dict[str, str] | None = None, log: Path) -> subprocess.Popen[str]:
    err = open(log, "w")  # noqa: SIM115 - the child holds it; closed when the test's tmp goes
    return subprocess.Popen(
        [sys.executable, "-m", "flexhrc", *args],
        stdout=subprocess.PIPE, stderr=err, text=True, env=env or subprocess_env(),
    )  # fmt: skip


def _document(proc: subprocess.Popen[str], log: Path, *others: Path) -> dict[str, Any]:
    """The ``--json`` document of a finished run (with the processes' stderr tails on failure)."""
    try:
        out, _ = proc.communicate(timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, _ = proc.communicate()
        tails = {p.name: p.read_text()[-1500:] for p in (log, *others) if p.exists()}
        raise AssertionError(f"no end within {TIMEOUT} s: {tails}") from None
    assert proc.returncode in (0, 1) and out.strip(), (
        f"exit {proc.returncode}: {log.read_text()[-2000:]}"
    )
    data: dict[str, Any] = json.loads(out)
    return data


def _stop(procs: list[subprocess.Popen[str]]) -> None:
    for p in procs:
        if p.poll() is None:
            p.kill()
    for p in procs:
        p.wait(10)


@pytest.fixture(scope="module")
def starter(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The scenario `flexhrc scenario new` writes, as a user gets it."""
    folder = tmp_path_factory.mktemp("starter") / "my_task"
    done = subprocess.run(
        [sys.executable, "-m", "flexhrc", "scenario", "new", str(folder)],
        capture_output=True, text=True, env=subprocess_env(), timeout=TIMEOUT,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    return folder / "scenario.yaml"


@cache
def _reference(what: str, seed: int, simulator: str | None) -> dict[str, Any]:
    """The cooperation of ``flexhrc.scenario.run`` in this process (computed once)."""
    summary: dict[str, Any] = sc.run(sc.load(what), seed=seed, simulator=simulator).summary
    return summary


def _cooperation(data: dict[str, Any]) -> dict[str, Any]:
    """What must be equal in every configuration."""
    return {
        "outcome": data["outcome"],
        "solved_hyperarcs": [(h["hyperarc"], h["agent"]) for h in data["solved_hyperarcs"]],
        "by_agent": data["by_agent"],
        "total_s": data["timing"]["total_s"],
    }


def _agents(what: str) -> tuple[list[str], list[str]]:
    """(robot arms, operators) of the scenario, by its domain."""
    agents = list(sc.load(what).domain.agents.values())
    return [a.name for a in agents if not a.is_human], [a.name for a in agents if a.is_human]


def _options(seed: int, simulator: str | None) -> list[str]:
    return ["--seed", str(seed)] + (["--simulator", simulator] if simulator else [])


def _run_cli(what: str, seed: int, simulator: str | None, tmp: Path) -> dict[str, Any]:
    """`flexhrc run --json --log` and `flexhrc replay --json` of its log: both must tell the
    in-process run's cooperation."""
    log = tmp / "run.jsonl"
    data = _document(
        _flexhrc("run", what, "--json", "--quiet", *_options(seed, simulator), "--log", str(log),
                 log=tmp / "run.err"),
        tmp / "run.err",
    )  # fmt: skip
    replayed = _document(
        _flexhrc("replay", str(log), "--json", log=tmp / "replay.err"), tmp / "replay.err"
    )
    assert _cooperation(replayed) == _cooperation(data), "replay of the run's --log"
    return data


def _cell(what: str, seed: int, simulator: str | None, tmp: Path) -> dict[str, Any]:
    err = tmp / "cell.err"
    return _document(
        _flexhrc("cell", what, "--json", "--quiet", *_options(seed, simulator), log=err), err
    )


def _zenoh(what: str, seed: int, simulator: str | None, tmp: Path) -> dict[str, Any]:
    pytest.importorskip("zenoh")
    from .cell.helpers import human, kill_all, robot, start_cell

    arms, operators = _agents(what)
    s = ["--seed", str(seed)]
    sim = _options(seed, simulator)  # the manager's branches and the arms' world
    # the cell binds a port the system picks and reports it before the agents start
    manager, port = start_cell(what, tmp / "cell.db", *sim, log=tmp / "cell.err")
    procs = [manager]
    try:
        procs += [robot(what, arm, port, tmp / f"{arm}.err", *sim) for arm in arms]
        procs += [human(what, name, port, tmp / f"{name}.err", *s) for name in operators]
        data = _document(procs[0], tmp / "cell.err", *(tmp / f"{a}.err" for a in arms))
        for p in procs[1:]:  # every agent leaves when the cell announces its end
            assert p.wait(30) == 0
    finally:
        kill_all(procs)
    return data


def _ros2(what: str, seed: int, simulator: str | None, tmp: Path) -> dict[str, Any]:
    from flexhrc.ros2 import available

    if not available():
        pytest.skip("rclpy or a standard ROS 2 message package is not importable")
    arms, operators = _agents(what)
    env = subprocess_env()
    env["ROS_DOMAIN_ID"] = str(random.SystemRandom().randint(1, 100))
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env["FASTDDS_BUILTIN_TRANSPORTS"] = "UDPv4"  # a killed node leaves nothing in /dev/shm
    env["PYTHONUNBUFFERED"] = "1"
    common = [what, "--cell", f"t{uuid.uuid4().hex[:8]}", "--seed", str(seed), "--quiet"]
    # the arms execute on the kinematic robot model: the manager simulates branches on it too
    assert simulator == "kinematic"
    manager = ["--json", "--simulator", simulator]
    procs = [_flexhrc("ros2", "cell", *common, *manager, env=env, log=tmp / "cell.err")]
    try:
        procs += [
            _flexhrc("ros2", "arm", *common, "--arm", a, env=env, log=tmp / f"{a}.err")
            for a in arms
        ]
        procs += [
            _flexhrc("ros2", "human", *common, "--name", h, env=env, log=tmp / f"{h}.err")
            for h in operators
        ]
        data = _document(procs[0], tmp / "cell.err", *(tmp / f"{a}.err" for a in arms))
        for p in procs[1:]:  # every node leaves when the cell announces its end
            p.wait(30)
    finally:
        _stop(procs)
    return data


PANEL_SPEED = 50.0  # simulated seconds per wall second at the panel (its clock is the wall's)
CHROMIUM = os.environ.get("FLEXHRC_CHROMIUM") or shutil.which("chromium") or "/usr/bin/chromium"


def _panel(what: str, seed: int, simulator: str | None, tmp: Path) -> dict[str, Any]:
    """The person at the panel in headless chromium: they click 'done' on every step the
    page asks of them (a passive operator), to the end; the panel's report."""
    sync_api = pytest.importorskip("playwright.sync_api")
    pytest.importorskip("uvicorn")
    if not os.path.exists(CHROMIUM):
        pytest.skip(f"no chromium at {CHROMIUM} (apt-get install chromium)")
    from flexhrc.web import PanelConfig, serve_panel

    config = PanelConfig(what, seed=seed, speed=PANEL_SPEED, simulator=simulator or "auto", port=0)
    panel = serve_panel(config)
    ended = (
        "() => { const o = document.querySelector('#outcome');"
        " return (o && o.dataset.outcome && o.dataset.outcome !== 'running')"
        " || document.querySelector('#suggestions tr.mine button.done') !== null; }"
    )
    try:
        with sync_api.sync_playwright() as pw:
            browser = pw.chromium.launch(
                executable_path=CHROMIUM, headless=True, timeout=30_000,
                args=["--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage"],
            )  # fmt: skip
            try:
                page = browser.new_page()
                page.set_default_timeout(TIMEOUT * 1000 / 4)
                # the engineer's view: the person clicks 'done' in the suggestions table
                page.goto(panel.url + ("&" if "?" in panel.url else "?") + "view=engineer")
                while True:
                    page.wait_for_function(ended)
                    if page.locator("#outcome").get_attribute("data-outcome") != "running":
                        break
                    try:  # the arms may have taken the step meanwhile: look again
                        page.locator("#suggestions tr.mine button.done").first.click(timeout=2000)
                    except sync_api.TimeoutError:
                        continue
            finally:
                browser.close()
        assert panel.wait(TIMEOUT), "the panel's cooperation did not end"
        data: dict[str, Any] = panel.report().to_dict()
    finally:
        panel.close()
    return data


# Where configurations differ today, with the reason (strict xfails, so a fix shows as XPASS
# and its entry goes). None: the arms' joints travel with commands and acks (docs/protocol.md).
KNOWN: dict[tuple[str, str], str] = {}


def _cases() -> list[Any]:
    """scenario x configuration, each with its marks (slow; a known difference)."""
    out = []
    for sid, what in SCENARIOS:
        for conf in _configurations():
            marks = list(conf.marks)
            if (sid, conf.id) in KNOWN:
                marks.append(pytest.mark.xfail(reason=KNOWN[sid, conf.id], strict=True))
            out.append(pytest.param(sid, what, *conf.values, id=f"{sid}-{conf.id}", marks=marks))
    return out


CONFIGURATIONS = {"run": _run_cli, "cell": _cell, "zenoh": _zenoh, "ros2": _ros2, "panel": _panel}


def _cannot(what: str, configuration: str) -> str | None:
    """Why ``configuration`` legitimately cannot run scenario ``what`` (None: it can)."""
    if configuration != "ros2":
        return None
    from flexhrc.cell.components import execution_model

    # a ROS 2 arm node streams the joint motions of an arm of the kinematic robot model
    model = execution_model("kinematic", sc.load_scenario(what))
    inner = getattr(model, "execution", None)
    if inner is None:
        return "the kinematic simulator is not installed (the sim extra)"
    known = inner.sim.robot.arm_names
    arms, _ = _agents(what)
    other = [a for a in arms if a not in known]
    if other:
        return (
            f"a ROS 2 arm node plays an arm of the kinematic robot model ({', '.join(known)}); "
            f"the scenario's {', '.join(other)} is none of them"
        )
    return None


@pytest.mark.parametrize(("name", "what", "configuration", "seed", "simulator"), _cases())
def test_every_front_end_gives_the_same_cooperation(
    name: str,
    what: str,
    configuration: str,
    seed: int,
    simulator: str | None,
    tmp_path: Path,
    starter: Path,
) -> None:
    if what == "starter":
        what = str(starter)
    reason = _cannot(what, configuration)
    if reason is not None:
        pytest.skip(reason)
    reference = _reference(what, seed, simulator)
    if configuration == "run":  # every scenario is solved by the reference itself
        assert reference["outcome"] == "solved", reference["reason"]
    data = CONFIGURATIONS[configuration](what, seed, simulator, tmp_path)
    if configuration == "panel":
        # the panel's clock is the wall clock (the person takes the time they take): the same
        # outcome and report; the same cooperation needs a simulated clock at the panel
        assert set(reference) - {"wall_s"} <= set(data)
        assert data["outcome"] == reference["outcome"], data.get("reason")
        return
    assert _cooperation(data) == _cooperation(reference), data.get("reason")
