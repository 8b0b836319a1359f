"""What ``flexhrc sim`` does, callable from Python: one action simulated on the robot model.

The simulator lives in the ``sim`` extra; :func:`simulate_action` imports it when called.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from flexhrc.errors import FlexhrcError

if TYPE_CHECKING:
    from flexhrc.action.control import Obstacle
    from flexhrc.action.simulator import ActionOutcome, Pose


def simulate_action(
    action: str,
    arm: str = "left",
    target: Pose | None = None,
    *,
    after: Sequence[str] = (),
    after_target: Pose | None = None,
    obstacles: Sequence[Obstacle] = (),
    human_hand: Sequence[float] | None = None,
    dt: float = 0.02,
    time_budget_s: float = 10.0,
    trajectory: bool = False,
    view: str | Path | None = None,
) -> tuple[dict[str, Any], ActionOutcome]:
    """Simulate ``action`` of ``arm`` (``left``, ``right`` or ``both``) towards ``target`` with
    the kinematic task-priority controller, from rest or from where the ``after`` actions
    (simulated first, at ``after_target`` or else ``target``) leave it; ``view`` renders the
    whole motion to a .png (last frame) or .gif. The report (with ``trajectory``: the
    trajectory too) and the outcome; an ``after`` action that fails is a :class:`FlexhrcError`.
    """
    from flexhrc.action.simulator import KinematicSimulator

    t0 = time.perf_counter()
    pick = target if after_target is None else after_target
    sim = KinematicSimulator(dt=dt, time_budget_s=time_budget_s)
    before = sim.simulate_sequence(
        arm, [(name, pick) for name in after], obstacles=obstacles, human_hand=human_hand
    )
    if not before.success:
        failed = before.outcomes[-1]
        raise FlexhrcError(f"--after {after[len(before.outcomes) - 1]} failed: {failed.reason}")
    start = before.final_state
    out = sim.simulate(arm, action, target, start=start, obstacles=obstacles, human_hand=human_hand)
    data: dict[str, Any] = out.to_dict(trajectory=trajectory)
    data["target"] = None if target is None else target.to_dict()
    data["obstacles"] = [o.to_dict() for o in obstacles]
    data["after"] = [
        {"action": b.action, "duration_s": round(b.duration_s, 4)} for b in before.outcomes
    ]
    data["real_time_factor"] = (
        round(out.duration_s / out.wall_s, 1) if out.wall_s > 0 and out.duration_s > 0 else None
    )
    if view:
        from flexhrc.action.simulator import Trajectory
        from flexhrc.action.view import render
        from flexhrc.files import atomic_output

        title = (
            f"{out.action} by {out.arm}: {'success' if out.success else 'FAILED'} "
            f"({out.duration_s:.2f} s simulated)"
        )
        with atomic_output(view) as tmp:
            render(
                Trajectory.concatenate([*(b.trajectory for b in before.outcomes), out.trajectory]),
                tmp,
                obstacles=obstacles,
                human_hand=human_hand,
                goal=None if target is None else list(target.position),
                rest=start.q,
                title=title,
            )
        data["view"] = str(view)
    data["total_wall_s"] = round(time.perf_counter() - t0, 4)
    return data, out
