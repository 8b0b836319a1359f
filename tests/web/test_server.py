"""Serving the panel: the address option, the loopback rule, the token on a real server."""

from __future__ import annotations

import json
import subprocess
import sys
import urllib.error
import urllib.request
from pathlib import Path

import pytest

from flexhrc.errors import FlexhrcError
from flexhrc.web.server import check_bind, is_loopback, parse_web_address
from tests.conftest import subprocess_env

TOKEN = "tok-1234567890"


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("127.0.0.1:8080", ("127.0.0.1", 8080)),
        (":9000", ("127.0.0.1", 9000)),
        ("localhost", ("localhost", 8080)),
        ("[::1]:8081", ("::1", 8081)),
        ("0.0.0.0:0", ("0.0.0.0", 0)),
        ("", ("127.0.0.1", 8080)),
    ],
)
def test_web_address(text: str, expected: tuple[str, int]) -> None:
    assert parse_web_address(text) == expected


@pytest.mark.parametrize(
    "bad", ["host:port", "1.2.3.4:70000", "::1:80", "[::1:80", "a b:80", "h:-1"]
)
def test_bad_web_address_names_the_option(bad: str) -> None:
    with pytest.raises(FlexhrcError, match="--web"):
        parse_web_address(bad)


def test_loopback_rule() -> None:
    for host in ("127.0.0.1", "127.1.2.3", "localhost", "::1"):
        assert is_loopback(host)
        check_bind(host, None)
    for host in ("0.0.0.0", "::", "10.1.2.3", "panel.example"):
        assert not is_loopback(host)
        with pytest.raises(FlexhrcError, match="--token"):
            check_bind(host, None)
        check_bind(host, TOKEN)  # allowed with a token
    with pytest.raises(FlexhrcError, match="at least"):
        check_bind("0.0.0.0", "short")
    with pytest.raises(FlexhrcError, match="--token"):
        check_bind("0.0.0.0", "has spaces in it")


def test_cli_refuses_a_non_loopback_address_without_token() -> None:
    r = subprocess.run(
        [sys.executable, "-m", "flexhrc", "panel", "--web", "0.0.0.0:0", "--exit-when-done"],
        capture_output=True,
        text=True,
        env=subprocess_env(),
        timeout=60,
    )
    assert r.returncode == 2
    assert "--token" in r.stderr and "Traceback" not in r.stderr


def test_cell_refuses_a_non_loopback_panel_without_token_before_any_work(tmp_path: Path) -> None:
    store = tmp_path / "cell.db"
    r = subprocess.run(
        [sys.executable, "-m", "flexhrc", "cell", "table_assembly", "--store", str(store),
         "--web", "0.0.0.0:0"],
        capture_output=True, text=True, env=subprocess_env(), timeout=60,
    )  # fmt: skip
    assert r.returncode == 2
    assert "--token" in r.stderr and "Traceback" not in r.stderr
    assert not store.exists()  # refused before the store was created
    r = subprocess.run(
        [sys.executable, "-m", "flexhrc", "cell", "table_assembly", "--token", "abcdefgh12"],
        capture_output=True, text=True, env=subprocess_env(), timeout=60,
    )  # fmt: skip
    assert r.returncode == 2 and "--token is only used with --web" in r.stderr


def test_with_a_token_requests_and_websockets_without_it_get_401() -> None:
    pytest.importorskip("uvicorn")
    from websockets.exceptions import InvalidStatus
    from websockets.sync.client import connect

    from flexhrc.web.local import PanelConfig, serve_panel, table_legs

    config = PanelConfig(
        table_legs(4, unreachable_bolts=(2,)),
        speed=1000,
        simulator="analytic",
        port=0,
        token=TOKEN,
    )
    with serve_panel(config) as panel:
        server = panel.server
        assert server is not None
        base = f"http://127.0.0.1:{server.port}"
        for path in ("/", "/api/state", "/static/panel.js"):
            with pytest.raises(urllib.error.HTTPError) as err:
                urllib.request.urlopen(base + path, timeout=5)
            assert err.value.code == 401, path
        post = urllib.request.Request(
            base + "/api/human",
            data=b'{"take": "human_3"}',
            headers={"Content-Type": "application/json"},
            method="POST",
        )
        with pytest.raises(urllib.error.HTTPError) as err:
            urllib.request.urlopen(post, timeout=5)
        assert err.value.code == 401
        with pytest.raises(InvalidStatus) as denied:
            connect(f"ws://127.0.0.1:{server.port}/ws", open_timeout=5).close()
        assert denied.value.response.status_code == 401
        ok = urllib.request.Request(
            base + "/api/state", headers={"Authorization": f"Bearer {TOKEN}"}
        )
        with urllib.request.urlopen(ok, timeout=5) as r:
            assert json.loads(r.read())["outcome"] in ("running", "solved")
        with connect(f"ws://127.0.0.1:{server.port}/ws?token={TOKEN}", open_timeout=5) as ws:
            assert "outcome" in json.loads(ws.recv(timeout=5))


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["panel", "--speed", "nan"], "--speed"),
        (["panel", "--speed", "-1"], "--speed"),
        (["panel", "--legs", "0"], "--legs"),
        (["panel", "--web", "localhost:http"], "--web"),
        (["panel", "--web", "0.0.0.0:0"], "--token"),
        (["panel", "--web", "127.0.0.1:0", "--token", "short"], "--token"),
        (["panel", "--unreachable-bolt", "9"], "--unreachable-bolt 9"),
        (["panel", "no_such_scenario"], "no_such_scenario"),
        (["panel", "kitchen_drawer", "--legs", "3"], "--legs"),
        (["panel", "--simulator", "wrong"], "--simulator"),
    ],
)
def test_panel_command_bad_input_is_one_line_and_exit_2(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    from flexhrc.cli import main

    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and message in err and "Traceback" not in err


def test_serve_panel_binds_port_0_and_reports_the_real_port(tmp_path: Path) -> None:
    """The server binds the port itself (no number picked first and bound later by someone
    else): ``port=0`` takes a free one and the URL names it."""
    pytest.importorskip("uvicorn")
    from flexhrc.web.local import PanelConfig, serve_panel

    store = tmp_path / "panel.db"
    config = PanelConfig("kitchen_drawer", simulator="analytic", port=0, store=store)
    with serve_panel(config) as panel:
        assert panel.server is not None and panel.server.port > 0
        assert panel.url == f"http://127.0.0.1:{panel.server.port}/"
        with urllib.request.urlopen(panel.url + "api/state", timeout=5) as r:
            state = json.loads(r.read())
        assert state["scenario"] == "kitchen_drawer" and state["cell"] == "panel"
        # the port is taken: a second panel on it is one clear error and starts nothing
        busy = PanelConfig("kitchen_drawer", port=panel.server.port)
        with pytest.raises(FlexhrcError, match="cannot listen there"):
            serve_panel(busy)
    assert store.exists()  # every event of the panel's cell, for `flexhrc replay`


def test_serve_panel_refuses_a_non_loopback_address_without_token_first() -> None:
    from flexhrc.web.local import PanelConfig, serve_panel

    with pytest.raises(FlexhrcError, match="--token"):
        serve_panel(PanelConfig("no_such_scenario", host="0.0.0.0", port=0))
