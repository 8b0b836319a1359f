"""Assemble a cooperation with perception in the loop from a scenario's parts.

:func:`perceived_run` takes what any cooperation needs (graph, domain, the scenario's knowledge
base — which here is the *truth*) and returns a :class:`~flexhrc.sensing.run.
PerceivedCooperationRun` whose manager starts from the same base with the positions of the
perceivable parts forgotten, and a perception component looking at the simulated workspace.
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
    types: Iterable[str] = TABLE_PARTS,
    repair: bool = False,
    nudges: Iterable[Any] = (),
    false_reports: Iterable[Any] = (),
    camera: dict[str, Any] | None = None,
    **run_kw: Any,
) -> Any:
    """A :class:`PerceivedCooperationRun` over ``truth`` (see the module docstring)."""
    try:
        from flexhrc.sensing.camera import HeadCamera
        from flexhrc.sensing.perception import PerceptionComponent
        from flexhrc.sensing.run import PerceivedCooperationRun, forget_positions
        from flexhrc.sensing.world import SimulatedWorkspace
    except ImportError as exc:  # pragma: no cover - only without the extras
        raise OptionalDependencyError(
            "perception in the loop", "sim,perception", exc.name or "pybullet"
        ) from exc
    types = list(types)
    world, _ = SimulatedWorkspace.from_knowledge(truth, types=types)
    if not world.parts:
        raise FlexhrcError(
            f"--perception scene: the scenario has no part of type {', '.join(types)} "
            "with a size to see (a length and a diameter, or a width and a depth)"
        )
    belief = forget_positions(truth, types)
    perception = PerceptionComponent(world, belief, camera=HeadCamera(**(camera or {})))
    return PerceivedCooperationRun(
        graph,
        domain,
        belief,
        world,
        perception,
        repair=repair,
        nudges=nudges,
        false_reports=false_reports,
        **run_kw,
    )


__all__ = ["TABLE_PARTS", "perceived_run"]
