"""An authenticated cell (issue 20, Build 2; probe 2026-12-02, section 6).

Zenoh's own TLS with mutual authentication, configured by `--zenoh-config` files that `flexhrc
certs DIR` writes: agents with a certificate of the lab's CA run the table assembly to `solved`;
a peer without one cannot publish into the cell (its `stop`, `end` and ack change nothing) nor
read from it; a listener other hosts reach is refused without TLS. On loopback without TLS, the
agents obey only an `end` of their protocol version and run, and a command resent after a
spoofed `stop` is answered instead of waited for. Every process listens on 127.0.0.1, on a port
it binds itself (`--listen tls/127.0.0.1:0 --ready-file`).
"""

from __future__ import annotations

import json
import stat
import subprocess
import time
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("zenoh")
pytest.importorskip("cryptography")

from cryptography import x509

from flexhrc.cell import RobotAgent
from flexhrc.cell import protocol as P
from flexhrc.cell.components import execution_model, world_of
from flexhrc.cli import main
from flexhrc.errors import FlexhrcError
from flexhrc.scenario.builtin.table import table_assembly
from flexhrc.transport import InProcessBus
from flexhrc.transport.certs import make_lab
from flexhrc.transport.zenoh import (
    TransportError,
    ZenohTransport,
    check_exposure,
    load_zenoh_config,
    zenoh_config,
)

from .helpers import finish, flexhrc, kill_all, listening_port, rows, wait_until

# -- flexhrc certs ------------------------------------------------------------------------------


def test_certs_writes_a_ca_and_a_certificate_key_and_config_per_name(tmp_path: Path) -> None:
    lab = make_lab(tmp_path / "lab", names=["cell", "left"], days=30)
    ca = x509.load_pem_x509_certificate(lab.ca.read_bytes())
    for name in ("cell", "left"):
        cert = x509.load_pem_x509_certificate(lab.cert(name).read_bytes())
        cert.verify_directly_issued_by(ca)  # raises unless the lab's CA signed it
        cn = cert.subject.get_attributes_for_oid(x509.oid.NameOID.COMMON_NAME)[0].value
        assert cn == name  # what Zenoh's access control matches (cert_common_names)
        assert stat.S_IMODE(lab.key(name).stat().st_mode) == 0o600
        config = load_zenoh_config(lab.config(name))  # Zenoh itself reads it
        assert json.loads(config.get_json("transport/link/tls/enable_mtls")) is True
        assert json.loads(config.get_json("transport/link/tls/connect_certificate")) == str(
            lab.cert(name)
        )
    assert stat.S_IMODE((lab.dir / "ca.key").stat().st_mode) == 0o600
    assert json.loads(load_zenoh_config(lab.config("cell")).get_json("listen/endpoints")) == [
        "tls/127.0.0.1:7447"
    ]
    assert json.loads(load_zenoh_config(lab.config("left")).get_json("connect/endpoints")) == [
        "tls/127.0.0.1:7447"
    ]
    assert not list(lab.dir.glob(".*"))  # no temporary file left behind
    # an agent added later joins the same lab: same CA, the existing certificates kept
    before = lab.cert("left").read_bytes()
    again = make_lab(lab.dir, names=["cell", "left", "camera"])
    assert again.kept == ["cell", "left"] and lab.cert("left").read_bytes() == before
    cert = x509.load_pem_x509_certificate(again.cert("camera").read_bytes())
    cert.verify_directly_issued_by(ca)
    # the cell's access control names every agent of the lab, the one added later too
    acl = json.loads(load_zenoh_config(lab.config("cell")).get_json("access_control"))
    assert acl["enabled"] and acl["default_permission"] == "deny"
    assert [s["cert_common_names"] for s in acl["subjects"]] == [["camera"], ["left"]]


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["--names", "cell,le ft"], "--names 'le ft'"),
        (["--names", ","], "--names"),
        (["--days", "0"], "--days"),
        (["--hosts", "bad host!"], "--hosts"),
        (["--listen", "tcp/127.0.0.1:7447"], "--listen"),
    ],
)
def test_certs_refuses_bad_arguments_with_one_error_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], says: str
) -> None:
    assert main(["certs", str(tmp_path / "lab"), *args]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error:") and says in err


def test_certs_command_prints_what_it_wrote(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["certs", str(tmp_path / "lab"), "--names", "cell,left", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert set(data["names"]) == {"cell", "left"}
    assert all(Path(f).is_file() for n in data["names"].values() for f in n.values())


# -- CA14b: a listener other hosts reach needs TLS with mutual authentication --------------------


@pytest.mark.parametrize(
    "argv",
    [
        ["cell", "table_assembly", "--transport", "zenoh", "--listen", "tcp/0.0.0.0:7448"],
        [
            "cell",
            "table_assembly",
            "--transport",
            "zenoh",
            "--listen",
            "tcp/0.0.0.0:7448",
            "--quiet",
        ],
        ["cell", "table_assembly", "--transport", "zenoh", "--listen", "tcp/192.0.2.1:7448"],
        ["cell", "table_assembly", "--transport", "zenoh", "--listen", "tls/0.0.0.0:7448"],
        ["agent", "robot", "table_assembly", "--arm", "left", "--listen", "tcp/0.0.0.0:7449"],
    ],
)
def test_ca14b_listen_beyond_loopback_without_tls_is_refused(
    argv: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    """Refused before anything is bound, even with --quiet (nothing binds: no port is used)."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: --listen ")
    assert "Securing a cell" in err


def test_ca14b_a_config_with_tls_and_mtls_may_listen_beyond_loopback(tmp_path: Path) -> None:
    lab = make_lab(tmp_path / "lab", names=["cell"])
    # checked on the configuration only: nothing is bound here
    check_exposure(zenoh_config(listen=["tls/0.0.0.0:7448"], file=lab.config("cell")))
    half = tmp_path / "half.json5"  # a server certificate, but any client may connect
    half.write_text(
        json.dumps(
            {
                "transport": {
                    "link": {
                        "tls": {
                            "listen_certificate": str(lab.cert("cell")),
                            "listen_private_key": str(lab.key("cell")),
                            "root_ca_certificate": str(lab.ca),
                        }
                    }
                }
            }
        )
    )
    with pytest.raises(TransportError, match="enable_mtls"):
        check_exposure(zenoh_config(listen=["tls/0.0.0.0:7448"], file=half))
    # loopback needs nothing
    check_exposure(zenoh_config(listen=["tcp/127.0.0.1:7448", "tcp/[::1]:7448"]))


def test_a_zenoh_config_file_is_taken_as_is_the_options_replace_its_endpoints(
    tmp_path: Path,
) -> None:
    file = tmp_path / "z.json5"
    file.write_text(
        '// a comment: json5\n{ mode: "peer", scouting: { multicast: { enabled: true } },\n'
        '  listen: { endpoints: ["tcp/127.0.0.1:7450"] }, connect: { endpoints: [] } }\n'
    )

    def get(config: Any, key: str) -> Any:
        return json.loads(config.get_json(key))

    config = zenoh_config(file=file)
    assert get(config, "listen/endpoints") == ["tcp/127.0.0.1:7450"]
    assert get(config, "scouting/multicast/enabled") is True  # the file said so
    assert get(config, "connect/retry")["period_max_ms"] == 1000  # flexhrc's, left at default
    config = zenoh_config(listen=["tcp/127.0.0.1:0"], connect=["tcp/127.0.0.1:7451"], file=file)
    assert get(config, "listen/endpoints") == ["tcp/127.0.0.1:0"]
    assert get(config, "connect/endpoints") == ["tcp/127.0.0.1:7451"]
    assert get(config, "adminspace/enabled") is True  # port 0: the cell reports its port
    # a file that leaves the listeners to Zenoh (every interface, plain tcp) is refused
    bare = tmp_path / "bare.json5"
    bare.write_text("{}")
    with pytest.raises(TransportError, match=r"--zenoh-config: listen endpoint tcp/\[::\]:0"):
        check_exposure(zenoh_config(file=bare))


def test_a_zenoh_config_zenoh_refuses_is_one_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.json5"
    bad.write_text("{ trasnport: {} }")
    with pytest.raises(FlexhrcError, match=r"--zenoh-config .*bad.json5: Zenoh refuses it"):
        load_zenoh_config(bad)
    with pytest.raises(FlexhrcError, match="no such file"):
        load_zenoh_config(tmp_path / "missing.json5")


# -- a TLS cell of four processes and three peers without a certificate ---------------------------


def _agent(
    scenario: str, kind: str, name: str, endpoint: str, config: Path, tmp_path: Path
) -> subprocess.Popen[str]:
    """`flexhrc agent robot|human` with the lab's config for ``name``."""
    option = "--arm" if kind == "robot" else "--name"
    return flexhrc(
        "agent", kind, scenario, option, name, "--connect", endpoint,
        "--zenoh-config", str(config), log=tmp_path / f"{name}.err",
    )  # fmt: skip


def _spoofer(endpoint: str, config: Path | None) -> tuple[ZenohTransport, list[Any]]:
    """A peer that tries the cell's endpoint and listens to what the cell sends."""
    bus = ZenohTransport(
        zenoh_config(connect=[endpoint], file=config),
        prefix="flexhrc/default",
        deliver="thread",
    )
    heard: list[Any] = []
    for topic in ("cmd/left", "cmd/right", "suggest/human", "state"):
        bus.subscribe(topic, heard.append)
    return bus, heard


@pytest.mark.slow
def test_tls_cell_is_solved_and_peers_without_a_certificate_change_nothing(
    tmp_path: Path,
) -> None:
    """P14, P15, P16, P10, P19 and P27 over TLS: the spoofed messages never reach the cell."""
    lab = make_lab(tmp_path / "lab", names=["cell", "left", "right", "human", "observer"])
    other = make_lab(tmp_path / "other", names=["left"])  # a certificate of another CA
    no_cert = tmp_path / "no_cert.json5"  # trusts the lab's CA, has no certificate of its own
    no_cert.write_text(json.dumps({"transport": {"link": {"tls": {
        "root_ca_certificate": str(lab.ca)}}}}))  # fmt: skip
    scenario, store, ready = "table_assembly", tmp_path / "cell.db", tmp_path / "cell.ready"
    manager = flexhrc(
        "cell", scenario, "--transport", "zenoh", "--agents", "external",
        "--listen", "tls/127.0.0.1:0", "--zenoh-config", str(lab.config("cell")),
        "--store", str(store), "--json", "--wait", "30", "--realtime", "10",
        "--ready-file", str(ready), log=tmp_path / "cell.err",
    )  # fmt: skip
    procs: list[subprocess.Popen[str]] = [manager]
    buses: list[ZenohTransport] = []
    try:
        port = listening_port(ready, manager)
        endpoint = f"tls/127.0.0.1:{port}"
        for kind, name in (("robot", "left"), ("robot", "right"), ("human", "human")):
            procs.append(_agent(scenario, kind, name, endpoint, lab.config(name), tmp_path))
        # a peer of the lab (the control: the cell's messages do reach a certified peer)
        observer, seen = _spoofer(endpoint, lab.config("observer"))
        buses.append(observer)
        spoofers = [
            _spoofer(f"tcp/127.0.0.1:{port}", None),  # plain TCP to the TLS port
            _spoofer(endpoint, no_cert),  # TLS without a client certificate
            _spoofer(endpoint, other.config("left")),  # a certificate of another CA
        ]
        buses += [bus for bus, _ in spoofers]
        got = wait_until(
            store, lambda r: any(k == "command" and "right" in b["agents"] for _, _, k, b in r), 60
        )
        cmd = next(b for _, _, k, b in got if k == "command" and "right" in b["agents"])
        for bus, _ in spoofers:
            bus.declare_token("alive/right")  # P27
            bus.publish("cmd/right", {"v": 1, "type": "stop", "id": cmd["id"], "reason": "spoof"})
            bus.publish("ack", {"v": 1, "type": "ack", "id": cmd["id"], "agent": "right",
                                "status": "done", "t": cmd["t"] + 0.01})  # fmt: skip
            bus.publish("human", {"v": 1, "type": "human_action", "id": "odd",
                                  "agent": "human", "action": "check(human, bolt_1)",
                                  "t": 1.0})  # fmt: skip
            bus.publish("state", {"v": 99, "type": "end", "outcome": "x"})
            bus.publish("state", {"v": 1, "type": "end", "outcome": "x"})
        assert not any(k == "outcome" for _, _, k, _ in rows(store)), "sent too late"
        data = finish(manager, timeout=120)
        for p in procs[1:]:
            assert p.wait(15) == 0
    finally:
        for bus in buses:
            bus.close()
        kill_all(procs)
    log = (tmp_path / "cell.err").read_text()
    assert data["outcome"] == "solved", log[-2000:]
    assert data["cell"]["dropped"] == 0 and "dropped" not in log
    assert seen, "the certified observer heard nothing: the test proves nothing"
    for _, heard in spoofers:  # nor can they read the cell (a session hears its own puts)
        assert [m for m in heard if m.get("type") in ("command", "suggestion", "state")] == []
    events = rows(store)
    acks = [b for _, _, k, b in events if k == "ack" and b["id"] == cmd["id"]]
    assert [a["status"] for a in acks] == ["done"] and acks[0].get("duration", 0) > 0
    assert not any(k == "agent_down" for _, _, k, _ in events)
    assert not any(b.get("id") == "odd" for _, _, k, b in events if k == "human_action")
    ref = finish(flexhrc("run", scenario, "--json", "--quiet"))
    for key in ("robot_actions", "human_actions", "decisions", "legs_by_agent", "by_agent"):
        assert data[key] == ref[key], key


# -- on loopback without TLS: what an agent can tell ---------------------------------------------


def _command(cid: int, action: str = "approach(left, leg1)") -> dict[str, Any]:
    world = world_of(table_assembly(segments="legs").world())
    return P.message(
        "command", id=cid, agents=["left"], action=action, t=1.0, expected_s=1.0, world=world,
        realtime=1000.0,
    )  # fmt: skip


def _arm(bus: InProcessBus) -> RobotAgent:
    return RobotAgent(
        "left", table_assembly(segments="legs"), bus, execution=execution_model("analytic")
    )


@pytest.mark.parametrize(
    ("case", "end"),
    [
        ("P16", {"v": 99, "type": "end", "outcome": "x"}),
        ("R2P6", {"v": 7, "type": "end"}),
        ("P15_no_outcome", {"v": 1, "type": "end"}),
        ("P15_other_run", {"v": 1, "type": "end", "outcome": "solved", "run": "someone-else"}),
        ("P15_no_run", {"v": 1, "type": "end", "outcome": "solved"}),
        ("P15_not_json_object", ["end"]),
    ],
)
def test_p15_p16_r2p6_an_agent_leaves_only_on_its_managers_end(case: str, end: Any) -> None:
    bus = InProcessBus(immediate=True)
    arm = _arm(bus)
    arm.run = "this-run"  # type: ignore[attr-defined]  # as run identity sets it
    bus.publish(P.STATE_TOPIC, end)
    assert arm.ended is None, case
    assert arm.dropped == (1 if isinstance(end, dict) else 0)
    bus.publish(P.STATE_TOPIC, P.message("end", outcome="solved", run="this-run"))  # the manager's
    assert arm.ended == "solved"
    arm.close()


def test_p14_a_command_resent_after_a_spoofed_stop_is_answered_failed() -> None:
    bus = InProcessBus(immediate=True)
    acks: list[dict[str, Any]] = []
    bus.subscribe(P.ACK_TOPIC, acks.append)
    arm = _arm(bus)
    bus.publish(P.cmd_topic("left"), _command(9))
    assert 9 in arm.running  # paced in real time: it is moving
    bus.publish(P.cmd_topic("left"), {"v": 1, "type": "stop", "id": 9, "reason": "spoof"})
    assert 9 not in arm.running and acks == []
    # the manager never sent that stop: it sends the command again, as it does every 2 s
    bus.publish(P.cmd_topic("left"), _command(9))
    assert [(a["id"], a["status"]) for a in acks] == [(9, "failed")]
    assert acks[0]["reason"] == "stopped before its end"
    bus.publish(P.cmd_topic("left"), _command(9))  # and the same answer again, not a new run
    assert len(acks) == 2 and acks[1] == acks[0] and arm.executed == [9]
    arm.close()


def test_p14_the_failed_answer_after_a_stop_names_its_run(tmp_path: Path) -> None:
    """Every ack names its run, in the message and in the agent's journal: the answer to a
    command resent after a stop left it out (the copy of the interrupted-command answer had
    it)."""
    bus = InProcessBus(immediate=True)
    acks: list[dict[str, Any]] = []
    bus.subscribe(P.ACK_TOPIC, acks.append)
    journal = tmp_path / "left.journal"
    arm = RobotAgent(
        "left", table_assembly(segments="legs"), bus, execution=execution_model("analytic"),
        journal=journal,
    )  # fmt: skip
    bus.publish(P.cmd_topic("left"), {**_command(9), "run": "r1"})
    bus.publish(P.cmd_topic("left"), {"v": 1, "type": "stop", "id": 9, "reason": "x", "run": "r1"})
    bus.publish(P.cmd_topic("left"), {**_command(9), "run": "r1"})
    assert [(a["id"], a["status"], a.get("run")) for a in acks] == [(9, "failed", "r1")]
    arm.close()
    lines = [json.loads(x) for x in journal.read_text().splitlines()]
    answer = next(x for x in lines if x.get("event") == "ack")
    assert answer["run"] == "r1" and answer["ack"]["run"] == "r1"


def test_p14_a_stop_of_another_run_is_dropped() -> None:
    bus = InProcessBus(immediate=True)
    arm = _arm(bus)
    command = {**_command(9), "run": "this-run"}  # the manager's commands name its run
    bus.publish(P.cmd_topic("left"), command)
    bus.publish(P.cmd_topic("left"), {"v": 1, "type": "stop", "id": 9, "run": "other"})
    assert 9 in arm.running and arm.dropped == 1
    arm.close()


# -- access control: a certified peer speaks only for itself ---------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("acl", [True, False], ids=["with_access_control", "control_without"])
def test_p27_a_certified_peer_cannot_declare_another_agents_token(
    tmp_path: Path, acl: bool
) -> None:
    """`flexhrc certs` gives the cell Zenoh's access control: a lab certificate named
    `intruder` may not declare `alive/right`, so the cell still waits for the real arm and
    gives up after --wait naming it. The control, the same config without access control: the
    token counts as the arm (a cell would start and send right's commands to nobody)."""
    lab = make_lab(tmp_path / "lab", names=["cell", "intruder"])
    config = lab.config("cell")
    if not acl:
        text = "\n".join(x for x in config.read_text().splitlines() if not x.startswith("//"))
        plain = json.loads(text)
        assert plain.pop("access_control")["enabled"] is True
        config = tmp_path / "cell_plain.json5"
        config.write_text(json.dumps(plain))
    ready = tmp_path / "cell.ready"
    manager = flexhrc(
        "cell", "table_assembly", "--transport", "zenoh", "--agents", "external",
        "--listen", "tls/127.0.0.1:0", "--zenoh-config", str(config), "--json", "--wait", "10",
        "--ready-file", str(ready), log=tmp_path / "cell.err",
    )  # fmt: skip
    intruder: ZenohTransport | None = None
    try:
        endpoint = f"tls/127.0.0.1:{listening_port(ready, manager)}"
        intruder = ZenohTransport(
            zenoh_config(connect=[endpoint], file=lab.config("intruder")),
            prefix="flexhrc/default",
        )
        alive: set[str] = set()
        intruder.watch_liveliness("alive/*", lambda key, up: alive.add(key) if up else None)
        deadline = time.monotonic() + 30
        while "alive/manager" not in alive:  # connected: it sees the manager's token
            assert time.monotonic() < deadline and manager.poll() is None, "never connected"
            intruder.wait(0.1)
            intruder.flush()
        intruder.declare_token("alive/right")
        manager.communicate(timeout=60)
    finally:
        if intruder is not None:
            intruder.close()
        kill_all([manager])
    assert manager.returncode == 2
    err = (tmp_path / "cell.err").read_text()
    missing = err.split("error: no agent process for ", 1)[1].split(" after ", 1)[0]
    assert set(missing.split(", ")) == ({"left", "right", "human"} if acl else {"left", "human"})


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["cell", "table_assembly", "--zenoh-config", "z.json5"], "--zenoh-config goes with"),
        (["cell", "table_assembly", "--transport", "zenoh", "--zenoh-config", "missing.json5"],
         "--zenoh-config missing.json5: no such file"),
        (["agent", "robot", "table_assembly", "--arm", "left", "--zenoh-config", "missing.json5"],
         "--zenoh-config missing.json5: no such file"),
        (["agent", "perception", "table_assembly", "--zenoh-config", "missing.json5"],
         "--zenoh-config missing.json5: no such file"),
    ],
)  # fmt: skip
def test_zenoh_config_option_errors_are_one_line(
    argv: list[str], says: str, capsys: pytest.CaptureFixture[str], tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:  # fmt: skip
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: ") and says in err


# -- ROS 2: the same rule, with SROS2 for TLS ------------------------------------------------------


def _ros2_check() -> Any:
    from flexhrc.ros2 import available

    if not available():
        pytest.skip("rclpy or a standard ROS 2 message package is not importable")
    from flexhrc.ros2.transport import check_exposure as check

    return check


@pytest.mark.parametrize(
    ("env", "refused"),
    [
        ({}, "unset: SUBNET"),
        ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"}, "=SUBNET"),
        ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "ROS_STATIC_PEERS": "192.0.2.5"},
         "ROS_STATIC_PEERS names 192.0.2.5"),
        ({"ROS_SECURITY_ENABLE": "true", "ROS_SECURITY_STRATEGY": "Permissive"}, "SUBNET"),
        ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}, None),
        ({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "ROS_STATIC_PEERS": "127.0.0.1"}, None),
        ({"ROS_LOCALHOST_ONLY": "1"}, None),
        ({"ROS_SECURITY_ENABLE": "true", "ROS_SECURITY_STRATEGY": "Enforce"}, None),
    ],
)  # fmt: skip
def test_ros2_discovery_beyond_this_host_needs_sros2(
    env: dict[str, str], refused: str | None
) -> None:
    check = _ros2_check()
    if refused is None:
        check(env)
    else:
        with pytest.raises(FlexhrcError, match=refused):
            check(env)


def test_ros2_cell_with_subnet_discovery_is_refused_before_it_starts(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    _ros2_check()
    for var in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_LOCALHOST_ONLY", "ROS_SECURITY_ENABLE"):
        monkeypatch.delenv(var, raising=False)
    for argv in (
        ["ros2", "cell", "table_assembly"],
        ["ros2", "arm", "table_assembly", "--arm", "left"],
    ):
        assert main([*argv, "--quiet"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("error: ROS 2 discovery reaches other hosts")
