"""Write your own behaviour and run a task with it (flexhrc.behavior, paper 002).

``Inspect`` brings the arm's wrist camera to a pose above an object, holds it there while the
picture is exposed, and returns. It is a :class:`~flexhrc.behavior.BehaviorNode`, so the network
treats it like any other leaf: it is activated by its parent goal, bids for an arm's mutex with
its activation potential (here 1 / distance from the arm to the camera pose) and, while the
picture is being taken, validity checking watches the object — if someone moves it, the
behaviour stops, releases the arm and competes again.

The task file names two behaviour types besides the default pick-and-place: ``inspect``
(declared below in Python) and ``glance`` (declared in the YAML itself from the built-in
``visit`` type).

Run it::

    python examples/custom_behavior.py            # add --plot inspect.png for a Gantt chart
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Mapping
from typing import Any

from flexhrc.behavior import (
    BehaviorFactory,
    BehaviorNetwork,
    BehaviorNode,
    NetworkParams,
    TabletopWorld,
    ValidityCheck,
    check_run,
    load_task_document,
    register_behavior_type,
)
from flexhrc.transport import Transport


class Inspect(BehaviorNode):
    """Look at ``obj`` from ``height`` metres above it for ``exposure`` seconds."""

    def __init__(
        self,
        name: str,
        obj: str,
        world: TabletopWorld,
        transport: Transport,
        params: NetworkParams,
        height: float = 0.3,
        exposure: float = 1.5,
    ) -> None:
        # `obj` is the object validity checking watches (and whose sensing wakes the node).
        super().__init__(name, world.arm_names, transport, params, obj)
        self.world = world
        self.height = height
        self.exposure = exposure
        self.motion: Any = None
        self.check: ValidityCheck | None = None

    def camera_pose(self) -> tuple[float, float, float]:
        x, y, z = self.world.object_position(self.object or "")
        return (x, y, z + self.height)

    # -- the hooks of BehaviorNode ---------------------------------------------------------
    def ready(self) -> bool:
        """Preconditions besides an arm: the object is on the table, in view."""
        return self.world.object_in_view(self.object or "")

    def bid(self, arm: str) -> float:
        """Activation potential for `arm`: the nearer the camera pose, the higher."""
        distance = math.dist(self.world.arms[arm].free_position, self.camera_pose())
        return 1.0 / max(distance, 1e-3)

    def start_action(self, arm: str) -> dict[str, object]:
        self.motion = self.world.start_move(arm, self.camera_pose(), self.exposure, self.now)
        self.check = ValidityCheck.watch(
            self.world, self.object or "", self._params.validity_threshold
        )
        return {"object": self.object, "duration": round(self.motion.duration, 3)}

    def step_action(self) -> str:
        exposing = self.now < self.motion.t_grasp  # the camera is at the pose until then
        if exposing and self.check is not None and not self.check.valid(self.world):
            return "invalid"  # the object moved during the exposure: reset, try again
        return "done" if self.now >= self.motion.t_end else "running"

    def abort_action(self) -> dict[str, object]:
        moved = self.check.displacement(self.world) if self.check else 0.0
        self.world.abort(self.motion.arm, self.now)
        return {"object": self.object, "reason": "object moved", "moved": round(moved, 4)}


def inspect_type(leaf: str, params: Mapping[str, Any]) -> BehaviorFactory:
    """The `inspect` type of task files: `object` (default: the leaf name), `height`,
    `exposure`."""
    obj = str(params.get("object", leaf))
    height = float(params.get("height", 0.3))
    exposure = float(params.get("exposure", 1.5))
    return lambda name, world, transport, p: Inspect(
        name, obj, world, transport, p, height, exposure
    )


register_behavior_type("inspect", inspect_type)

TASK_FILE = """
name: inspect the mug, then lay one dish
task:
  THEN:
    - mug                                  # pick-and-place (the default type)
    - AND: [look_at_mug, {OR: [plate, bowl]}]
    - glance_at_tray
types:
  glance: {base: visit, offset: [0, 0, 0.15], dwell: 0.5}     # a type declared in YAML
behaviors:
  look_at_mug: {type: inspect, object: mug, height: 0.25}     # the type declared in Python
  glance_at_tray: {type: glance, object: tray}
world:
  arms:
    - {name: left, home: [0.15, 0.3, 0.95]}
    - {name: right, home: [0.15, -0.3, 0.95]}
  objects:
    mug: {position: [0.5, 0.2, 0.75], target: [0.7, 0.0, 0.75]}
    plate: {position: [0.45, -0.25, 0.75], target: [0.8, -0.1, 0.75]}
    bowl: {position: [0.6, 0.35, 0.75], target: [0.8, 0.1, 0.75]}
    tray: {position: [0.75, 0.0, 0.75]}
"""


def main() -> int:
    ap = argparse.ArgumentParser(description="run a task with a custom 'inspect' behaviour")
    ap.add_argument("--plot", metavar="FILE", help="write the Gantt chart (needs flexhrc[viz])")
    args = ap.parse_args()
    doc = load_task_document(TASK_FILE, "<custom_behavior.py>")
    assert doc.world is not None
    net = BehaviorNetwork(doc.task, doc.world, behaviors=doc.behaviors)
    result = net.run()
    print(f"task: {doc.task.to_prefix()}")
    for ev in result.log:
        if ev.kind in ("start", "done", "reset"):
            arm = ev.data.get("arm")
            print(f"{ev.t:6.1f} s  {ev.kind:<5}  {ev.source:<15} on {arm}")
    violations = check_run(doc.task, result.runs)
    print(f"outcome: {result.outcome} after {result.time:.1f} s; order: {', '.join(result.order)}")
    print("constraints: " + ("respected" if not violations else "; ".join(violations)))
    if args.plot:
        from flexhrc.behavior.plot import gantt

        print(f"gantt chart: {gantt(result, args.plot)}")
    return 0 if result.outcome == "done" and not violations else 1


if __name__ == "__main__":
    raise SystemExit(main())
