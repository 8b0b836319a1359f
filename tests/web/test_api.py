"""The panel's JSON API and its guard (Starlette's test client: no sockets)."""

from __future__ import annotations

import json
from typing import Any

import pytest

pytest.importorskip("starlette")
pytest.importorskip("httpx2")

from starlette.testclient import TestClient, WebSocketDenialResponse

from flexhrc.web.app import COOKIE, create_app
from flexhrc.web.local import LocalPanel
from tests.web.helpers import TABLE_HUMAN_BOLT_2, human_next, until, waiting_for_operator

TOKEN = "s3cret-token-for-tests"
LOCAL = "http://127.0.0.1:8080"
WS = "ws://127.0.0.1:8080/ws"


@pytest.fixture
def waiting_coop(local_panel: Any) -> LocalPanel:
    """A cooperation waiting for the operator (bolt 2 out of the arms' reach; the arms have
    done the rest)."""
    panel: LocalPanel = local_panel(TABLE_HUMAN_BOLT_2)
    until(panel, waiting_for_operator)
    return panel


MALFORMED: list[tuple[bytes, str, int]] = [
    (b'{"action": ', "application/json", 400),  # truncated JSON
    (b"[]", "application/json", 400),  # not an object
    (b'"pick_up(human, leg2)"', "application/json", 400),  # a bare string
    (b"{}", "application/json", 400),  # no key
    (b'{"action": "pick_up(human, leg2)", "take": "human_2"}', "application/json", 400),
    (b'{"cmd": "rm -rf /"}', "application/json", 400),  # unknown key
    (b'{"action": 5}', "application/json", 400),  # wrong type
    (b'{"action": null}', "application/json", 400),
    (b'{"action": ["pick_up", "human"]}', "application/json", 400),
    (b"{\"action\": \"__import__('os').system('id')\"}", "application/json", 400),  # code
    (b'{"action": NaN}', "application/json", 400),
    (b'{"take": "../../etc/passwd"}', "application/json", 400),
    (b'{"take": ""}', "application/json", 400),
    (b"\xff\xfe\x00garbage", "application/json", 400),  # not UTF-8
    (b"", "application/json", 400),  # empty
    (b"[" * 2000 + b"]" * 2000, "application/json", 400),  # deeply nested
    (json.dumps({"action": "x" * 5000}).encode(), "application/json", 413),  # too large
    (b'{"action": "pick_up(human, leg2)"}', "text/plain", 415),  # a cross-site form's type
    (b'{"action": "fly(human, leg2)"}', "application/json", 404),  # unknown action
    (b'{"action": "pick_up(human, leg99)"}', "application/json", 404),  # unknown object
    (b'{"take": "no_such_arc"}', "application/json", 404),  # unknown hyper-arc
    (b'{"action": "screw(human, leg3, bolt_4)"}', "application/json", 409),  # not now
    (b'{"action": "grasp(left, leg2)"}', "application/json", 409),  # a robot's action
]


def test_state_has_the_contract_keys(waiting_coop: LocalPanel) -> None:
    with TestClient(create_app(waiting_coop), base_url=LOCAL) as client:
        r = client.get("/api/state")
        assert r.status_code == 200
        state = r.json()
        assert state["outcome"] == "running"
        assert state["events"] == len(waiting_coop.cell.events)
        assert all({"element", "kind", "cost", "graph"} <= set(s) for s in state["suggestions"])
        assert all({"name", "kind", "status", "alive"} <= set(a) for a in state["agents"])
        assert state["waiting"].startswith("waiting for the operator")
        page = client.get("/")
        assert page.status_code == 200 and "/static/panel.js" in page.text
        csp = page.headers["content-security-policy"]
        assert "default-src 'self'" in csp and "frame-ancestors 'none'" in csp
        assert page.headers["referrer-policy"] == "no-referrer"  # the URL may carry ?token=
        assert client.get("/static/panel.js").status_code == 200
        assert client.get("/static/panel.css").status_code == 200


def test_assets_come_from_the_package_only() -> None:
    import re
    from pathlib import Path

    from flexhrc.web.app import static_dir

    root = Path(static_dir())
    files = sorted(f for f in root.rglob("*") if f.is_file())
    assert {f.name for f in files} >= {"index.html", "panel.js", "panel.css", "scene3d.js"}
    # the vendored three.js: an XML namespace, a link in a console warning, two regex literals
    vendored = {
        "http://www.w3.org/1999/xhtml",
        "https://discourse.threejs.org/t/updates-to-lighting-in-three-js-r155/53733.",
        "//i.test(e",
        "//i.test(t",
    }
    for f in files:
        urls = set(re.findall(r"(?:https?:)?//[A-Za-z0-9.-]+\.[a-z]{2,}[^\s\"')]*", f.read_text()))
        allowed = {"http://www.w3.org/2000/svg"}  # an XML namespace only
        if f.relative_to(root).parts[0] == "vendor":
            allowed |= vendored
            assert (f.parent / "LICENSE").is_file(), f  # every vendored library with its licence
        assert urls <= allowed, (f.name, urls - allowed)


def test_malformed_bodies_get_4xx_and_change_nothing(waiting_coop: LocalPanel) -> None:
    assert len(MALFORMED) >= 10
    with TestClient(create_app(waiting_coop), base_url=LOCAL) as client:
        before = client.get("/api/state").json()
        for body, ctype, status in MALFORMED:
            r = client.post("/api/human", content=body, headers={"content-type": ctype})
            assert r.status_code == status, (body[:60], r.text)
            assert r.json()["error"], body[:60]
        for body in (b'{"robot": "nobody"}', b'{"robot": 1}', b"{}", b'{"robot": "human"}'):
            r = client.post("/api/stop", content=body, headers={"content-type": "application/json"})
            assert 400 <= r.status_code < 500, body
        assert client.get("/api/state").json() == before


def test_done_advances_the_cooperation(waiting_coop: LocalPanel) -> None:
    with TestClient(create_app(waiting_coop), base_url=LOCAL) as client:
        (nxt,) = human_next(waiting_coop)
        with client.websocket_connect(WS) as ws:
            first = json.loads(ws.receive_text())
            r = client.post("/api/human", json={"action": nxt})
            assert r.status_code == 200, r.text
            assert r.json()["action"] == nxt
            pushed = json.loads(ws.receive_text())
            assert pushed["events"] > first["events"]
            assert [s["next"] for s in pushed["suggestions"] if s["owner"] == "human"] != [nxt]


def test_a_token_guards_every_request_and_the_websocket(waiting_coop: LocalPanel) -> None:
    app = create_app(waiting_coop, token=TOKEN)
    with TestClient(app, base_url="http://panel.example:8080") as client:
        for path in ("/", "/api/state", "/static/panel.js"):
            assert client.get(path).status_code == 401, path
        assert (
            client.get("/api/state", headers={"authorization": "Bearer wrong-token"}).status_code
            == 401
        )
        r = client.post("/api/human", json={"action": human_next(waiting_coop)[0]})
        assert r.status_code == 401
        assert human_next(waiting_coop)  # nothing happened
        with (
            pytest.raises(WebSocketDenialResponse) as denied,
            client.websocket_connect("ws://panel.example:8080/ws"),
        ):
            pass
        assert denied.value.status_code == 401
        assert (
            client.get("/api/state", headers={"authorization": f"Bearer {TOKEN}"}).status_code
            == 200
        )
        page = client.get(f"/?token={TOKEN}")
        assert page.status_code == 200
        assert COOKIE in page.headers["set-cookie"] and "HttpOnly" in page.headers["set-cookie"]
        assert client.get("/static/panel.js").status_code == 200  # the cookie now
        with client.websocket_connect(f"ws://panel.example:8080/ws?token={TOKEN}") as ws:
            assert json.loads(ws.receive_text())["outcome"] == "running"


def test_without_token_only_loopback_hosts_and_same_origin_websockets(
    waiting_coop: LocalPanel,
) -> None:
    with TestClient(create_app(waiting_coop), base_url="http://evil.example:8080") as client:
        assert client.get("/api/state").status_code == 400  # DNS rebinding
    with TestClient(create_app(waiting_coop), base_url=LOCAL) as client:
        with (
            pytest.raises(WebSocketDenialResponse) as denied,
            client.websocket_connect(WS, headers={"origin": "http://evil.example"}),
        ):
            pass
        assert denied.value.status_code == 403
        with client.websocket_connect(WS, headers={"origin": LOCAL}) as ws:
            assert json.loads(ws.receive_text())["outcome"] == "running"
