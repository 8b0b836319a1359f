"""Assemble a cooperation with perception in the loop from a scenario's parts.

:func:`perceived_run` takes what any cooperation needs (graph, domain, the scenario's knowledge
base — which here is the *truth*) and returns a :class:`~flexhrc.sensing.loop.
PerceivedCell` — the cell configured with perception in the loop — whose manager starts from
the same base with the positions of the perceivable parts forgotten, and whose perception agent
looks at the simulated workspace.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from flexhrc.errors import FlexhrcError, OptionalDependencyError
from flexhrc.knowledge import KnowledgeBase
from flexhrc.representation import OnlineGraph
from flexhrc.taskmanager.domain import Domain

#: The object types of the table assembly that the head camera perceives.
TABLE_PARTS = ("leg", "tabletop")


def perceived_run(
    graph: OnlineGraph,
    domain: Domain,
    truth: KnowledgeBase,
    *,
    types: Iterable[str] | None = None,
    nudges: Iterable[Any] = (),
    false_reports: Iterable[Any] = (),
    camera: dict[str, Any] | None = None,
    **run_kw: Any,
) -> Any:
    """A :class:`~flexhrc.sensing.loop.PerceivedCell` over ``truth`` (see the module docstring).

    ``types``: the object types the camera perceives; by default every object with a body
    (a length and a diameter: a rod lying on the table; a width and a depth: a board).
    """
    try:
        from flexhrc.sensing.camera import HeadCamera
        from flexhrc.sensing.loop import PerceivedCell
    except ImportError as exc:  # pragma: no cover - only without the extras
        raise OptionalDependencyError(
            "perception in the loop", "sim,perception", exc.name or "pybullet"
        ) from exc
    return PerceivedCell(
        graph,
        domain,
        truth,
        types=types,
        destinations=destinations(graph, domain, truth),
        camera=HeadCamera(**(camera or {})),
        nudges=nudges,
        false_reports=false_reports,
        **run_kw,
    )


def destinations(graph: OnlineGraph, domain: Domain, kb: KnowledgeBase) -> dict[str, list[str]]:
    """Object -> the places the task's actions will move it to: the constant ``moves_to``
    argument of every action of the graph that ``carries`` something (``place_tabletop(?top,
    assembly_pose)``: every tabletop may go to ``assembly_pose``)."""
    out: dict[str, list[str]] = {}
    for name in graph.elements():
        if graph.kind(name) != "hyperarc":
            continue
        for text in graph.definition_of(name).hyperarcs[graph.local_name(name)].actions:
            try:
                schema, terms = domain.invocation(text)
            except FlexhrcError:  # an action the domain lacks: the manager reports it
                continue
            carries, moves_to = getattr(schema, "carries", None), getattr(schema, "moves_to", None)
            if not carries or not moves_to:
                continue
            binding = dict(zip(schema.variables, terms, strict=False))
            place, carried = binding.get(moves_to), binding.get(carries)
            if place is None or place.startswith("?") or place not in kb.objects:
                continue
            kind = dict(schema.parameters).get(carries, "")
            objs = (
                [carried]
                if carried and not carried.startswith("?")
                else [o.id for o in kb.objects_of_type(kind)]
            )
            for o in objs:
                out.setdefault(o, [])
                if place not in out[o]:
                    out[o].append(place)
    return out


__all__ = ["TABLE_PARTS", "destinations", "perceived_run"]
