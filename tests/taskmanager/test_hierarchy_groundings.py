"""Groundings through the hierarchy (paper 000, IV-B, eqs. 15-16): a variable the upper
hyper-arc binds is bound in the lower instance it creates (M1), and the lower instance's result
grounds the upper hyper-arc's parent (M2).

The tasks are small two-layer drawers: one lower graph ``roller`` (mount a slide, fasten it)
whose leaf says only ``loose(?slide)``, so alone it would take either slide — slide_1 first (it
sorts first and lies nearer the arm). The upper layer decides which one each instance is for.
"""

from __future__ import annotations

import copy
import re
from pathlib import Path
from typing import Any

import pytest
import yaml

from flexhrc import scenario
from flexhrc.errors import FormatError
from flexhrc.representation import load

ROLLER: dict[str, Any] = {
    "root": "roller_on",
    "nodes": [
        {"name": "drawer", "state": "drawer(?d)"},
        {"name": "slide", "state": "loose(?slide)"},
        {"name": "held", "state": "mounting(?slide)"},
        {"name": "roller_on", "state": "mounted(?slide)"},
    ],
    "hyperarcs": [
        {"name": "mount", "children": ["drawer", "slide"], "parent": "held", "weight": 1,
         "actions": ["mount(?who, ?slide)"]},
        {"name": "fasten", "children": ["held"], "parent": "roller_on", "weight": 1,
         "actions": ["fasten(?who, ?slide)"]},
    ],
}  # fmt: skip

DOMAIN: dict[str, Any] = {
    "agents": {
        "arm": {"kind": "robot", "types": ["robot"], "base": [0.0, 0.0, 0.4],
                "rest": [0.3, 0.0, 0.5], "reach": 0.9},
    },
    "actions": {
        "mount": {"parameters": {"?who": "agent", "?slide": "slide"}, "agents": {"choice": "?who"},
                  "pre": ["loose(?slide)"], "add": ["mounting(?slide)"],
                  "delete": ["loose(?slide)"], "moves_to": "?slide", "duration": 1.0},
        "fasten": {"parameters": {"?who": "agent", "?slide": "slide"},
                   "agents": {"choice": "?who"}, "pre": ["mounting(?slide)"],
                   "add": ["mounted(?slide)"], "delete": ["mounting(?slide)"],
                   "moves_to": "?slide", "duration": 1.0},
        "label": {"parameters": {"?who": "agent", "?slide": "slide"},
                  "agents": {"choice": "?who"}, "pre": ["mounted(?slide)"],
                  "add": ["labelled(?slide)"], "duration": 1.0},  # (from where it is)
    },
}  # fmt: skip

WORLD: dict[str, Any] = {
    "objects": {
        "box": {"type": "drawer", "position": [0.5, 0.0, 0.0]},
        "slide_1": {"type": "slide", "position": [0.35, 0.1, 0.0]},
        "slide_2": {"type": "slide", "position": [0.6, -0.3, 0.0]},
    },
    "facts": ["drawer(box)", "loose(slide_1)", "loose(slide_2)"],
}


def doc(top: dict[str, Any], *, facts: list[str] = (), roller: dict | None = None) -> dict:
    world = copy.deepcopy(WORLD)
    world["facts"] += list(facts)
    return {
        "flexhrc": 1,
        "name": "drawer",
        "top": "top",
        "graphs": {"top": top, "roller": roller or copy.deepcopy(ROLLER)},
        "domain": copy.deepcopy(DOMAIN),
        "world": world,
        "humans": [],
    }


def write(tmp_path: Path, d: dict, name: str = "task.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(d, sort_keys=False, default_flow_style=None), encoding="utf-8")
    return path


def acted_on(tmp_path: Path, d: dict) -> dict[str, str]:
    """Run the task: every robot action carried out -> its element (solved, or it failed)."""
    result = scenario.run(scenario.load(write(tmp_path, d)), seed=0)
    assert result.summary["outcome"] == "solved", result.summary["reason"]
    return {e["action"]: e["element"] for e in result.events if e["type"] == "command"}


# --- (a) the upper hyper-arc binds which slide; its lower instance acts on that one -----------
SPARE = {
    "root": "fitted",
    "nodes": [
        {"name": "box_ready", "state": "drawer(box)"},
        # which slide: the spare one (the roller graph alone knows nothing of spares)
        {"name": "spare_slide", "state": "loose(?s) & spare(?s)"},
        {"name": "fitted", "state": "mounted(?s)"},
    ],
    "hyperarcs": [
        {"name": "fit_roller", "children": ["box_ready", "spare_slide"], "parent": "fitted",
         "weight": 1, "lower": "roller"},
    ],
}  # fmt: skip


def test_the_lower_graph_alone_takes_slide_1(tmp_path):
    """The variant without an upper layer: the roller graph run on its own mounts slide_1 —
    what the hierarchical run below would do if the binding were not carried through M1."""
    d = doc(copy.deepcopy(ROLLER), facts=["spare(slide_2)"])
    d["graphs"] = {"roller": d["graphs"]["top"]}
    del d["top"]
    assert acted_on(tmp_path, d) == {
        "mount(arm, slide_1)": "mount",
        "fasten(arm, slide_1)": "fasten",
    }


def test_the_slide_the_upper_hyper_arc_binds_is_the_one_its_lower_instance_mounts(tmp_path):
    acts = acted_on(tmp_path, doc(copy.deepcopy(SPARE), facts=["spare(slide_2)"]))
    assert acts == {
        "mount(arm, slide_2)": "fit_roller/mount",
        "fasten(arm, slide_2)": "fit_roller/fasten",
    }


def test_a_binding_an_upper_action_made_is_carried_down_too(tmp_path):
    """Which slide is chosen by an action of the upper layer (``pick``): its grounding reaches
    the node ``picked`` (within a graph) and from there the lower instance (M1)."""
    top = {
        "root": "fitted",
        "nodes": [
            {"name": "box_ready", "state": "drawer(box)"},
            {"name": "spares", "state": "spare(?s)"},
            {"name": "picked", "state": "loose(?s) & picked(?s)"},
            {"name": "fitted", "state": "mounted(?s)"},
        ],
        "hyperarcs": [
            {"name": "pick", "children": ["spares"], "parent": "picked", "weight": 1,
             "actions": ["pick(?who, ?s)"]},
            {"name": "fit_roller", "children": ["box_ready", "picked"], "parent": "fitted",
             "weight": 1, "lower": "roller"},
        ],
    }  # fmt: skip
    d = doc(top, facts=["spare(slide_2)"])
    d["domain"]["actions"]["pick"] = {
        "parameters": {"?who": "agent", "?s": "slide"},
        "agents": {"choice": "?who"},
        "add": ["picked(?s)"],
        "duration": 1.0,  # from where it is: the arm stays nearer slide_1
    }
    acts = acted_on(tmp_path, d)
    assert acts["pick(arm, slide_2)"] == "pick"
    assert acts["mount(arm, slide_2)"] == "fit_roller/mount"
    assert "mount(arm, slide_1)" not in acts


# --- (b) two instances of one lower graph, bound to different objects by the upper layer ------
TWO = {
    "root": "done",
    "nodes": [
        {"name": "box_ready", "state": "drawer(box)"},
        {"name": "first_slide", "state": "loose(slide_2)"},
        {"name": "half", "state": "mounted(slide_2)"},
        {"name": "second_slide", "state": "loose(slide_1)"},
        {"name": "done", "state": "mounted(slide_1) & mounted(slide_2)"},
    ],
    "hyperarcs": [
        {"name": "fit_first", "children": ["box_ready", "first_slide"], "parent": "half",
         "weight": 1, "lower": "roller"},
        {"name": "fit_second", "children": ["half", "second_slide"], "parent": "done",
         "weight": 1, "lower": "roller"},
    ],
}  # fmt: skip


def test_two_instances_of_one_lower_graph_act_on_the_objects_the_upper_layer_names(tmp_path):
    """Both slides are loose throughout fit_first, so no precondition tells the two instances
    apart (in kitchen_drawer one does): only the upper layer's literals do. Without M1 the
    first instance would mount slide_1, and half (mounted(slide_2)) would never hold."""
    acts = acted_on(tmp_path, doc(copy.deepcopy(TWO)))
    assert acts == {
        "mount(arm, slide_2)": "fit_first/mount",
        "fasten(arm, slide_2)": "fit_first/fasten",
        "mount(arm, slide_1)": "fit_second/mount",
        "fasten(arm, slide_1)": "fit_second/fasten",
    }


def test_the_instance_binding_shows_in_the_decisions(tmp_path):
    result = scenario.run(scenario.load(write(tmp_path, doc(copy.deepcopy(TWO)))), seed=0)
    first = next(
        e for e in result.events if e["type"] == "decision" and e["element"] == "fit_first/mount"
    )
    assert [b["grounding"]["?slide"] for b in first["branches"]] == ["slide_2"]


# --- M2: the lower instance's result grounds the upper parent --------------------------------
def test_the_lower_result_grounds_a_variable_of_the_upper_parent(tmp_path):
    """The upper layer leaves ?s open: the lower instance picks the slide (slide_2, the only
    loose one), and the parent ``fitted: mounted(?s)`` is reached with ?s = slide_2, so
    ``label`` labels it — although slide_1 was mounted already and sorts first."""
    top = {
        "root": "labelled",
        "nodes": [
            {"name": "box_ready", "state": "drawer(box)"},
            {"name": "fitted", "state": "mounted(?s)"},
            {"name": "labelled", "state": "labelled(?s)"},
        ],
        "hyperarcs": [
            {"name": "fit_any", "children": ["box_ready"], "parent": "fitted", "weight": 1,
             "lower": "roller", "leaves": {"box_ready": ["drawer", "slide"]}},
            {"name": "label_it", "children": ["fitted"], "parent": "labelled", "weight": 1,
             "actions": ["label(?who, ?s)"]},
        ],
    }  # fmt: skip
    d = doc(top, facts=["mounted(slide_1)"])
    d["world"]["facts"].remove("loose(slide_1)")
    acts = acted_on(tmp_path, d)
    assert acts["mount(arm, slide_2)"] == "fit_any/mount"
    assert acts["label(arm, slide_2)"] == "label_it"
    assert "label(arm, slide_1)" not in acts


# --- the check at load: corresponding literals are the same up to renaming -------------------
def line_of(path: Path, needle: str) -> int:
    return next(i for i, t in enumerate(path.read_text().splitlines(), 1) if needle in t)


def graph_file(tmp_path: Path, d: dict) -> Path:
    """The graphs of a task alone, as a graph file."""
    return write(tmp_path, {k: d[k] for k in ("flexhrc", "top", "graphs")}, "graph.yaml")


@pytest.mark.parametrize(
    ("child_state", "roller_leaf", "why"),
    [
        # the upper layer names slide_1, the lower graph is only for slide_2
        ("loose(slide_1)", "loose(slide_2)", "names the object slide_2 where loose(slide_1)"),
        # the lower graph is only for slide_2, the upper one for any slide
        ("loose(?s)", "loose(slide_2)", "names the object slide_2 where loose(?s) has a variable"),
        # one lower variable would be two upper ones
        ("at(?s, ?p)", "at(?slide, ?slide)", "?slide would be both ?s and ?p"),
    ],
)
def test_literals_that_are_not_the_same_up_to_renaming_are_refused_with_file_and_line(
    tmp_path, child_state, roller_leaf, why
):
    d = doc(copy.deepcopy(SPARE))
    d["graphs"]["top"]["nodes"][1]["state"] = child_state
    d["graphs"]["roller"]["nodes"][1]["state"] = roller_leaf
    path = graph_file(tmp_path, d)
    with pytest.raises(FormatError) as err:
        load(path)
    assert err.value.source == str(path)
    assert err.value.line == line_of(path, "name: fit_roller")
    text = str(err.value)
    assert text.startswith(f"{path}:{err.value.line}: hyper-arc 'fit_roller': 'slide'")
    assert why in text and "M1, eq. 15" in text


@pytest.mark.parametrize("which", ["M1", "M2"])
def test_nodes_mapped_one_to_one_that_share_no_literal_are_refused(tmp_path, which):
    """An explicit M1 entry (``leaves:``) or M2 says this node *is* that one: stating formulas
    with nothing in common, they describe different things. (Implicit M1 relates all children
    to all leaves: there a child may speak of what no leaf does.)"""
    d = doc(copy.deepcopy(SPARE))
    top = d["graphs"]["top"]
    top["hyperarcs"][0]["leaves"] = {"box_ready": ["drawer"], "spare_slide": ["slide"]}
    if which == "M1":
        top["nodes"][1]["state"] = "free(?s)"
    else:
        top["nodes"][2]["state"] = "fitted(?s)"
    path = graph_file(tmp_path, d)
    with pytest.raises(FormatError) as err:
        load(path)
    assert "relates states that share nothing" in str(err.value)
    assert f"{which}, eq. 1" in str(err.value)
    assert err.value.line == line_of(path, "name: fit_roller")
    del top["hyperarcs"][0]["leaves"]
    if which == "M1":  # implicit: spare_slide may say what no leaf says
        load(graph_file(tmp_path, d))


def test_a_parent_the_lower_root_cannot_ground_is_refused(tmp_path):
    """M2: the upper parent says the lower graph mounts slide_1 whatever slide M1 gives it."""
    d = doc(copy.deepcopy(SPARE))
    d["graphs"]["top"]["nodes"][2]["state"] = "mounted(slide_1)"
    path = graph_file(tmp_path, d)
    with pytest.raises(FormatError) as err:
        load(path)
    assert "M2, eq. 16" in str(err.value) and "'roller_on'" in str(err.value)
    assert err.value.line == line_of(path, "name: fit_roller")


def test_the_error_reaches_the_command_line_as_one_line_and_exit_code_2(tmp_path, capsys):
    from flexhrc.cli import main

    d = doc(copy.deepcopy(SPARE))
    d["graphs"]["roller"]["nodes"][1]["state"] = "loose(slide_2)"
    path = graph_file(tmp_path, d)
    assert main(["graph", "validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}:{line_of(path, 'name: fit_roller')}: hyper-arc 'fit_roller'" in err
    assert "Traceback" not in err


# --- the shipped kitchen drawer: the authors' RollerAssembly, twice ---------------------------
def kitchen_slides(sc: scenario.Scenario) -> dict[str, set[str]]:
    """Instance of RollerAssembly (h8, h9) -> the slides its actions were given."""
    result = scenario.run(sc, seed=0)
    assert result.summary["outcome"] == "solved", result.summary["reason"]
    out: dict[str, set[str]] = {"h8": set(), "h9": set()}
    for e in result.events:
        if e["type"] not in ("command", "suggestion"):
            continue
        instance = (e.get("element") or "").split("/")[1:2]
        if instance and instance[0] in out:
            for action in e.get("actions") or [e["action"]]:
                out[instance[0]].update(re.findall(r"\bslide_\d\b", action))
    return out


def test_the_kitchen_drawers_roller_instances_are_bound_by_the_upper_layer():
    """kitchen.yaml's node_states give DrawerAssembly's slide nodes and RollerAssembly's their
    formulas: h8 (DrawerRollerSlide1) is slide_1's instance, h9 slide_2's. The decision of
    h8's first step has slide_1 alone although both slides are loose then."""
    sc = scenario.load("kitchen_drawer")
    assert kitchen_slides(sc) == {"h8": {"slide_1"}, "h9": {"slide_2"}}
    events: list[dict[str, Any]] = []
    scenario.run(sc, seed=0, sink=events.append)
    first = next(
        e for e in events if e["type"] == "decision" and e["element"] == "build_drawer/h8/h1"
    )
    tried = [b["grounding"]["?slide"] for b in first["branches"] + first.get("pruned", [])]
    assert tried and set(tried) == {"slide_1"}


def test_without_the_formulas_the_kitchen_drawer_lands_on_the_slides_by_a_precondition(tmp_path):
    """The variant without node_states (nothing passes through M1): h8 takes slide_2 — the
    one nearer the operator — and h9 slide_1 only because slide_2 is no longer loose."""
    import shutil

    src = Path(scenario.shipped_path("kitchen_drawer")).parent
    shutil.copytree(src, tmp_path / "k")
    path = tmp_path / "k" / "kitchen_drawer.yaml"
    text = path.read_text()
    path.write_text(
        text[: text.index("\n# ... nor state formulas")] + text[text.index("\ndomain:") :]
    )
    assert kitchen_slides(scenario.load(path)) == {"h8": {"slide_2"}, "h9": {"slide_1"}}


@pytest.mark.parametrize(
    ("states", "said"),
    [
        ({"roller/slide": "loose(slide_9)"}, "names the object slide_9 where loose(?s)"),
        ({"roller/nothing*": "loose(?slide)"}, "matches no node of the graph"),
        ({"roller/slide": "loose(?slide"}, "unbalanced '('"),
        ({"roller/slide": ["loose(?slide)"]}, "a formula such as"),
    ],
)
def test_node_states_faults_are_one_error_at_the_scenario_line(tmp_path, states, said):
    from flexhrc.scenario.format import ScenarioError

    d = doc(copy.deepcopy(SPARE), facts=["spare(slide_2)"])
    d["node_states"] = states
    path = write(tmp_path, d)
    with pytest.raises(ScenarioError) as err:
        scenario.load(path)
    assert said in str(err.value)
    assert f"{path}:{line_of(path, 'roller/')}: node_states" in str(err.value)  # the entry's


def test_node_states_give_a_graph_its_formulas(tmp_path):
    """The roller graph stated without formulas, given them by node_states: as if written in."""
    roller = copy.deepcopy(ROLLER)
    for node in roller["nodes"]:
        del node["state"]
    d = doc(copy.deepcopy(SPARE), facts=["spare(slide_2)"], roller=roller)
    d["node_states"] = {n["name"]: n["state"] for n in ROLLER["nodes"]}
    assert acted_on(tmp_path, d) == {
        "mount(arm, slide_2)": "fit_roller/mount",
        "fasten(arm, slide_2)": "fit_roller/fasten",
    }


def test_transitions_without_formulas_on_both_sides_pass_nothing():
    """The authors' ANDOR files state no formulas: their transitions carry no grounding (and
    cost nothing to check); kitchen_drawer's node_states make two of them carry one."""
    from flexhrc.scenario.format import graph_of

    plain = load(
        Path(scenario.shipped_path("kitchen_drawer")).with_name("kitchen_drawer.graph.yaml")
    )
    given = graph_of(scenario.shipped_path("kitchen_drawer"))
    for graph, expect in ((plain, set()), (given, {"h8", "h9"})):
        carried = {
            h.name
            for key in graph.used_keys()
            for h in graph.graphs[key].hyperarcs.values()
            if h.lower is not None and graph.transfer(key, h.name)
        }
        assert carried == expect
    assert given.transfer("drawer", "h9").down == {"?slide": "slide_2"}
