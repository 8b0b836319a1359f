"""The paper's whole table assembly (000, VI-D) as a scenario: three segments.

1. **tabletop placement** (Fig. 8): ``place_tabletop`` — one joint command of both arms
   (approach, grasp, carry with the two-arm relative-pose objective, release) from the stand
   to the assembly pose; the node it reaches, ``tabletop``, has the process ``hold(?top)``: both
   arms keep the tabletop still until it has settled, and only then is the node met. When the
   arms cannot (every branch scores 0, e.g. a fixture in the way), the operator is asked:
   ``human_places_tabletop`` (cost 3; not offered without an operator);
2. **legs fix** (Figs. 9-12): the first-order graph of :func:`flexhrc.scenarios.table_assembly.
   build_graph` — four cooperation paths per bolt;
3. **check** (Fig. 13): ``check_connections`` — the operator checks every bolt, in order. Its
   weight is 0 (checking costs the same on every path), so the suggestion costs of the legs fix
   are those of Figs. 9-12. Without an operator the segment is left out.

:class:`TableTask` wraps a :class:`~flexhrc.scenarios.table_assembly.TableScenario` (legs,
tabletop size, leg length, unreachable bolts, seed) and offers what ``demo table`` and a
:class:`~flexhrc.scenario.Scenario` need; the shipped ``table_assembly`` scenario file is
:func:`write_shipped`'s output for the default table.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import Any

import yaml

from flexhrc.knowledge import KnowledgeBase
from flexhrc.logic import parse_conjunction
from flexhrc.representation import AndOrGraph, HierarchicalGraph, Node
from flexhrc.representation.graph import Hyperarc
from flexhrc.scenario.model import HumanSpec, Scenario, WorldSpec
from flexhrc.scenarios.table_assembly import TableScenario, build_graph, tabletop_centre
from flexhrc.taskmanager.domain import Domain

#: Where the tabletop waits before the robot places it: on a stand 25 cm above its assembly pose
#: (metres), out of the way of anything on the table (the fixtures of --unreachable-bolt).
STAND_OFFSET = (0.0, 0.0, 0.25)


def task_graph(legs: int = 4, *, check: bool = True) -> HierarchicalGraph:
    """Placement + legs fix (+ check) as one first-order graph."""
    fix = build_graph(legs).top_graph
    fix_root = str(fix.root)
    root = "checked" if check else fix_root
    g = AndOrGraph("TableAssembly", root=root)
    g.add_node(Node("tabletop_on_stand", 0, parse_conjunction("tabletop(?top) & on_table(?top)")))
    for n in fix.nodes.values():
        if n.name == "tabletop":
            g.add_node(Node(n.name, n.weight, n.formula, ("hold(?top)",)))
        else:
            g.add_node(Node(n.name, n.weight, n.formula, n.processes))
    g.add_hyperarc(
        Hyperarc(
            "place_tabletop",
            ("tabletop_on_stand",),
            "tabletop",
            1,
            ("place_tabletop(?top, assembly_pose)",),
        )
    )
    if check:  # the operator places it when the arms cannot (the robot's way is cheaper)
        g.add_hyperarc(
            Hyperarc(
                "human_places_tabletop",
                ("tabletop_on_stand",),
                "tabletop",
                3,
                ("place_by_hand(human, ?top, assembly_pose)",),
            )
        )
    for h in fix.hyperarcs.values():
        g.add_hyperarc(Hyperarc(h.name, h.children, h.parent, h.weight, h.actions))
    if check:
        bolts = [f"bolt_{k}" for k in range(1, legs + 1)]
        g.add_node(
            Node("checked", 0, parse_conjunction(" & ".join(f"checked({b})" for b in bolts)))
        )
        g.add_hyperarc(
            Hyperarc(
                "check_connections",
                (fix_root,),
                "checked",
                0,
                tuple(f"check(human, {b})" for b in bolts),
            )
        )
    hierarchy = HierarchicalGraph.single(g)
    hierarchy.validate()
    return hierarchy


def task_domain_data() -> dict[str, Any]:
    text = resources.files("flexhrc.scenarios").joinpath("data/table_assembly/task_domain.yaml")
    data: dict[str, Any] = yaml.safe_load(text.read_text(encoding="utf-8"))
    return data


def task_domain(human: bool = True) -> Domain:
    data = task_domain_data()
    if not human:  # the human's actions stay in the domain, with nobody to do them
        data["agents"].pop("human")
    return Domain.from_dict(data, "table_assembly/task_domain.yaml")


class TableTask:
    """The three-segment table assembly for one :class:`TableScenario`'s objects."""

    def __init__(self, table: TableScenario, *, segments: str = "all"):
        self.table = table
        self.segments = segments
        self.legs = table.legs
        self.human = table.human

    def graph(self) -> HierarchicalGraph:
        if self.segments == "legs":
            return self.table.graph()
        return task_graph(self.legs, check=self.human)

    def domain(self) -> Domain:
        if self.segments == "legs":
            return self.table.domain()
        return task_domain(self.human)

    def knowledge(self) -> KnowledgeBase:
        kb = self.table.knowledge()
        if self.segments == "legs":
            return kb
        centre = tabletop_centre(self.table.size)
        kb.retract_fact("placed", "tabletop")
        kb.assert_fact("on_table", "tabletop")
        kb.move("tabletop", tuple(c + o for c, o in zip(centre, STAND_OFFSET, strict=True)))
        kb.add_object("assembly_pose", "place", centre)
        return kb

    def scenario(self, name: str = "table_assembly") -> Scenario:
        """As a :class:`Scenario` (the world comes from :meth:`knowledge`)."""
        domain = self.domain()
        humans = (HumanSpec("human"),) if self.human else ()

        return Scenario(
            name,
            "The FlexHRC+ table assembly: tabletop placement, legs fix, check (paper VI-D).",
            self.graph(),
            domain,
            WorldSpec(),
            humans,
            "analytic",
            world_factory=self.knowledge,
        )


# ----------------------------------------------------------------------------- shipped file --
def shipped_documents(table: TableScenario | None = None) -> tuple[str, str]:
    """(scenario file, graph file) of the shipped ``table_assembly`` scenario, as YAML text."""
    from flexhrc.representation.formats.yaml_format import dump_yaml

    task = TableTask(table or TableScenario())
    kb = task.knowledge()
    objects: dict[str, Any] = {}
    places: dict[str, Any] = {}
    for o in kb.objects.values():
        if o.id in task.domain().agents:
            continue
        if o.type == "place" and not o.attrs:
            places[o.id] = [round(v, 4) for v in o.position]
            continue
        spec: dict[str, Any] = {"type": o.type, "position": [round(v, 4) for v in o.position]}
        if o.size:
            spec["size"] = {k: round(v, 4) for k, v in o.size.items()}
        if o.fixed:
            spec["fixed"] = True
        if "reachable_by" in o.attrs:
            spec["reachable_by"] = list(o.attrs["reachable_by"])
        rest = {k: v for k, v in o.attrs.items() if k != "reachable_by"}
        if rest:
            spec["attrs"] = rest
        objects[o.id] = spec
    facts = sorted(
        f"{f[0]}({', '.join(f[1:])})"
        for f in kb.facts
        if len(f) > 1
        and not (
            len(f) == 2
            and kb.objects.get(f[1]) is not None
            and f[0] in kb.type_chain(kb.objects[f[1]].type)
        )
    )
    doc = {
        "flexhrc": 1,
        "name": "table_assembly",
        "description": "The FlexHRC+ table assembly in three segments (paper 000, VI-D): the "
        "robot places the tabletop with both arms and holds it (Fig. 8), robot and operator fix "
        "four legs (Figs. 9-12), the operator checks every connection (Fig. 13).",
        "graph": "table_assembly.graph.yaml",
        "domain": "task_domain.yaml",
        "world": {"objects": objects, "places": places, "facts": facts},
        "humans": [{"name": "human", "profile": "passive", "speed": 1.0}],
        "simulator": "analytic",
    }
    head = (
        "# The shipped table assembly (generated by flexhrc.scenario.table.write_shipped; "
        "`flexhrc demo table`\n# runs the same task for any number of legs and table size).\n"
    )
    body = yaml.safe_dump(doc, sort_keys=False, width=100, default_flow_style=None)
    return head + body, dump_yaml(task.graph())


def write_shipped(folder: str | Path) -> None:
    """Write ``table_assembly.yaml`` and ``table_assembly.graph.yaml`` into ``folder``."""
    scenario_text, graph_text = shipped_documents()
    folder = Path(folder)
    (folder / "table_assembly.yaml").write_text(scenario_text, encoding="utf-8")
    (folder / "table_assembly.graph.yaml").write_text(graph_text, encoding="utf-8")
