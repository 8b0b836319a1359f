"""The cell protocol: every malformed message is one clear ProtocolError."""

from __future__ import annotations

from typing import Any

import pytest

from flexhrc.cell import protocol as P

ACK = {"v": 1, "type": "ack", "id": 3, "agent": "left", "status": "done", "t": 2.5}


def test_good_messages_pass_and_message_builds_them() -> None:
    assert P.parse(dict(ACK)) == ACK
    msg = P.message("command", id=1, agents=["left"], action="rest(left)", t=0.0)
    assert msg["v"] == P.VERSION and msg["type"] == "command"
    P.parse({"v": 1, "type": "human_action", "id": "h:1", "agent": "human",
             "action": "pick_up(human, leg1)", "t": 1})  # fmt: skip


@pytest.mark.parametrize(
    ("data", "match"),
    [
        ([1, 2], "JSON object"),
        ("ack", "JSON object"),
        ({**ACK, "v": 2}, "version"),
        ({**ACK, "v": True}, "version"),
        ({k: v for k, v in ACK.items() if k != "v"}, "version"),
        ({**ACK, "type": "teleport"}, "unknown message type"),
        ({k: v for k, v in ACK.items() if k != "id"}, "missing field 'id'"),
        ({**ACK, "id": "3"}, "'id' must be int"),
        ({**ACK, "id": True}, "'id' must be int"),
        ({**ACK, "t": float("nan")}, "finite"),
        ({**ACK, "t": -1}, ">= 0"),
        ({**ACK, "status": "maybe"}, "status"),
        ({**ACK, "positions": {"leg1": [0, 1]}}, r"\[x, y, z\]"),
        ({**ACK, "positions": {"leg1": [0, 1, float("inf")]}}, r"\[x, y, z\]"),
        ({"v": 1, "type": "command", "id": 1, "agents": [], "action": "a", "t": 0}, "non-empty"),
        ({"v": 1, "type": "suggestion", "id": "s1", "element": "e", "actions": [3], "t": 0},
         "non-empty list of strings"),
    ],
)  # fmt: skip
def test_malformed_messages_are_refused_with_a_reason(data: Any, match: str) -> None:
    with pytest.raises(P.ProtocolError, match=match):
        P.parse(data)


def test_a_message_of_the_wrong_kind_for_the_topic_is_refused() -> None:
    with pytest.raises(P.ProtocolError, match="not expected"):
        P.parse(dict(ACK), expect="human_action")
