"""Random scenarios (random hierarchical graphs, a generic domain, random worlds and operators)
always end ``solved`` or ``failed`` with a reason: never hang, never raise."""

from __future__ import annotations

from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from flexhrc import scenario

from .helpers import write
from .invariants import check_invariants

DOMAIN: dict[str, Any] = {
    "agents": {},
    "actions": {
        "fetch": {
            "parameters": {"?who": "agent", "?x": "item"},
            "agents": {"choice": "?who"},
            "pre": ["on_table(?x)", "free(?who)"],
            "add": ["holding(?who, ?x)"],
            "delete": ["on_table(?x)", "free(?who)"],
            "moves_to": "?x",
            "duration": 1.0,
            "undo": "drop",
        },
        "fit": {
            "parameters": {"?who": "agent", "?x": "item"},
            "agents": {"choice": "?who"},
            "pre": ["holding(?who, ?x)"],
            "add": ["fitted(?x)", "free(?who)"],
            "delete": ["holding(?who, ?x)"],
            "moves_to": "?x",
            "duration": 0.5,
        },
        "drop": {
            "parameters": {"?who": "agent", "?x": "item"},
            "agents": {"choice": "?who"},
            "add": ["on_table(?x)", "free(?who)"],
            "delete": ["holding(?who, ?x)"],
            "duration": 0.2,
        },
        "tune": {
            "parameters": {"?who": "agent"},
            "agents": {"choice": "?who"},
            "duration": 0.3,
        },
    },
}
ARC_ACTIONS = (["fetch(?who, ?x)", "fit(?who, ?x)"], ["tune(?who)"], [])


@st.composite
def graphs(draw: Any, prefix: str, depth: int) -> dict[str, Any]:
    """A random AND/OR graph: levels of nodes, each above the leaves reached by 1-2 hyper-arcs
    (OR) of 1-2 children (AND) from the level below; maybe one hyper-arc with a lower graph."""
    levels = draw(st.integers(1, 3))
    width = [draw(st.integers(1, 3)) for _ in range(levels)] + [1]
    names = [[f"n{i}_{j}" for j in range(w)] for i, w in enumerate(width)]
    nodes = [{"name": n} for level in names for n in level]
    arcs: list[dict[str, Any]] = []
    lowers: dict[str, Any] = {}
    for i in range(1, len(names)):
        for n in names[i]:
            for k in range(draw(st.integers(1, 2))):
                children = draw(
                    st.lists(st.sampled_from(names[i - 1]), min_size=1, max_size=2, unique=True)
                )
                arc = {
                    "name": f"h_{n}_{k}",
                    "children": children,
                    "parent": n,
                    "weight": draw(st.integers(0, 3)),
                    "actions": draw(st.sampled_from(ARC_ACTIONS)),
                }
                if depth > 0 and not lowers and draw(st.booleans()):
                    key = f"{prefix}_low"
                    lowers[key] = draw(graphs(key, depth - 1))
                    arc["lower"] = key
                    arc["actions"] = []
                arcs.append(arc)
    root = names[-1][0]
    out = {prefix: {"root": root, "nodes": nodes, "hyperarcs": arcs}}
    for key, sub in lowers.items():
        out.update({key: sub[key]}, **{k: v for k, v in sub.items() if k != key})
    return out


@st.composite
def scenarios(draw: Any) -> tuple[dict[str, Any], str, int]:
    domain = {"agents": {}, "actions": DOMAIN["actions"]}
    robots = draw(st.integers(0, 2))
    humans = draw(st.integers(0 if robots else 1, 2))
    facts = []
    for r in range(robots):
        y = 0.15 if r == 0 else -0.15
        domain["agents"][f"arm{r}"] = {
            "kind": "robot", "types": ["arm"], "base": [0.0, y, 0.4], "rest": [0.3, y, 0.5],
            "reach": draw(st.sampled_from([0.5, 0.9])),
        }  # fmt: skip
        facts.append(f"free(arm{r})")
    ops = []
    for h in range(humans):
        domain["agents"][f"op{h}"] = {"kind": "human", "types": ["human"], "hand": [1.0, h, 0.1]}
        facts.append(f"free(op{h})")
        ops.append(
            {
                "name": f"op{h}",
                "profile": draw(st.sampled_from(["passive", "takeover", "cooperative", "random"])),
                "speed": draw(st.sampled_from([0.5, 1.0, 2.0])),
            }
        )
    items = {}
    for i in range(draw(st.integers(1, 4))):
        x = draw(st.floats(0.2, 1.2))
        y = draw(st.floats(-0.6, 0.6))
        items[f"item{i}"] = {"type": "item", "position": [round(x, 3), round(y, 3), 0.0]}
        facts.append(f"on_table(item{i})")
    doc = {
        "flexhrc": 1,
        "name": "random_task",
        "graphs": draw(graphs("top", 1)),
        "top": "top",
        "domain": domain,
        "world": {"objects": items, "facts": facts},
        "humans": ops,
    }
    return doc, draw(st.sampled_from(["conflicts", "paper"])), draw(st.integers(0, 1000))


@settings(
    max_examples=100,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(scenarios())
def test_random_scenarios_end_solved_or_failed_with_a_reason(tmp_path, case):
    doc, reaction, seed = case
    path = write(tmp_path, doc, "random.yaml")
    sc, faults = scenario.check(path)
    if sc is None:  # e.g. a graph hypothesis drew that the graph validation refuses
        assert all(f.message for f in faults)
        return
    result = scenario.run(sc, seed=seed, reaction=reaction, max_time_s=600.0)
    assert result.outcome in ("solved", "failed")
    if result.outcome == "failed":
        assert result.reason
    else:
        check_invariants(sc, result.events)
