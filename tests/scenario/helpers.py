"""Small scenario files written on the fly (each test changes one thing of a base task)."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import yaml

BASE: dict[str, Any] = {
    "flexhrc": 1,
    "name": "two_parts",
    "graphs": {
        "two_parts": {
            "root": "done",
            "nodes": [
                {"name": "ready", "state": "part(?p) & on_table(?p)"},
                {"name": "first_in", "state": "in(?p, tray)"},
                {"name": "done", "state": "in(a, tray) & in(b, tray)"},
            ],
            "hyperarcs": [
                {
                    "name": "put_first",
                    "children": ["ready"],
                    "parent": "first_in",
                    "weight": 1,
                    "actions": ["pick(?who, ?p)", "put(?who, ?p, tray)"],
                },
                {
                    "name": "put_second",
                    "children": ["first_in"],
                    "parent": "done",
                    "weight": 1,
                    "actions": ["pick(?who, ?q)", "put(?who, ?q, tray)"],
                },
            ],
        }
    },
    "domain": {
        "agents": {
            "human": {"kind": "human", "types": ["human"], "hand": [1.0, 0.0, 0.1]},
            "arm": {
                "kind": "robot",
                "types": ["robot"],
                "base": [0.0, 0.0, 0.4],
                "rest": [0.3, 0.0, 0.5],
                "reach": 0.9,
            },
        },
        "actions": {
            "pick": {
                "parameters": {"?who": "agent", "?p": "part"},
                "agents": {"choice": "?who"},
                "pre": ["on_table(?p)", "free(?who)"],
                "add": ["holding(?who, ?p)"],
                "delete": ["on_table(?p)", "free(?who)"],
                "moves_to": "?p",
                "duration": 1.0,
            },
            "put": {
                "parameters": {"?who": "agent", "?p": "part", "?to": "place"},
                "agents": {"choice": "?who"},
                "pre": ["holding(?who, ?p)"],
                "add": ["in(?p, ?to)", "free(?who)"],
                "delete": ["holding(?who, ?p)"],
                "moves_to": "?to",
                "carries": "?p",
                "duration": 1.0,
            },
        },
    },
    "world": {
        "objects": {
            "a": {"type": "part", "position": [0.4, 0.2, 0.0]},
            "b": {"type": "part", "position": [0.4, -0.2, 0.0]},
        },
        "places": {"tray": [0.55, 0.0, 0.0]},
        "facts": ["on_table(a)", "on_table(b)", "free(arm)", "free(human)"],
    },
    "humans": [{"name": "human", "profile": "passive", "speed": 1.0}],
}


def base() -> dict[str, Any]:
    return copy.deepcopy(BASE)


def write(tmp_path: Path, doc: dict[str, Any], name: str = "task.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(doc, sort_keys=False, default_flow_style=None), encoding="utf-8")
    return path


def line_of(path: Path, needle: str) -> int:
    """1-based number of the first line containing ``needle``."""
    for i, text in enumerate(path.read_text().splitlines(), 1):
        if needle in text:
            return i
    raise AssertionError(f"{needle!r} not in {path}")
