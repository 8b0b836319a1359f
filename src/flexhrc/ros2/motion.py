"""The joint path of one robot command, for every arm it moves, as the ROS 2 arm publishes it.

A command's ``JointTrajectory`` must start where the arm is and last what the command lasts on
the cell's clock, whatever simulated it:

* when the kinematic simulator integrated the command's motion (the bridge's motion kinds, a
  joint command of both arms), its path is taken as it ran
  (:meth:`~flexhrc.action.execution.ExecutionManager.joint_path`);
* otherwise (an action the analytic model times: a ``check``, a step declared with
  ``duration``, a kind the robot model has no motion for) the arm moves towards a nominal target
  — ``approach_height`` above the last object the action names, both hands at its sides for a
  joint command — along the path the controller finds there, re-timed with a minimum-jerk
  profile to the command's duration; with no object to go to, the arm stays where it is.

Either way the result runs from 0 to the command's simulated duration exactly (a path that ends
early is held at its end, one that runs longer is compressed).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

__all__ = ["action_target", "blend_start", "command_path", "fit_duration", "min_jerk"]

#: Joint samples of a re-timed (nominal) path.
NOMINAL_SAMPLES = 60


def min_jerk(s: np.ndarray) -> np.ndarray:
    """The minimum-jerk time scaling ``10 s^3 - 15 s^4 + 6 s^5`` on ``[0, 1]`` (zero velocity
    and acceleration at both ends)."""
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10.0 - 15.0 * s + 6.0 * s * s)


def fit_duration(
    t: np.ndarray, q: Mapping[str, np.ndarray], duration: float
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """``(t, q)`` lasting exactly ``duration``: held at its end when it is shorter, compressed
    in time when it is longer; a single sample becomes a stay from 0 to ``duration``."""
    t = np.asarray(t, dtype=float) - float(t[0])
    q = {a: np.asarray(v, dtype=float) for a, v in q.items()}
    end = float(t[-1])
    if duration <= 0:
        return np.zeros(1), {a: v[-1:].copy() for a, v in q.items()}
    if end <= 1e-9:
        return np.array([0.0, duration]), {a: np.vstack([v[0], v[-1]]) for a, v in q.items()}
    if end > duration + 1e-9:
        t = t * (duration / end)
    elif end < duration - 1e-9:
        t = np.append(t, duration)
        q = {a: np.vstack([v, v[-1]]) for a, v in q.items()}
    t[-1] = duration  # exactly: the last point's time_from_start is the command's duration
    return t, q


def blend_start(t: np.ndarray, q: np.ndarray, start: Sequence[float] | np.ndarray) -> np.ndarray:
    """``q`` moved so it begins at ``start`` and still ends where it ended: the offset at the
    start fades out with a minimum-jerk profile over the path (a follower arm whose leader
    planned from a slightly older joint state)."""
    q = np.asarray(q, dtype=float)
    offset = np.asarray(start, dtype=float) - q[0]
    if len(t) < 2 or float(np.max(np.abs(offset))) == 0.0:
        out = q.copy()
        out[0] = start
        return out
    fade = 1.0 - min_jerk(np.asarray(t, dtype=float) / float(t[-1]))
    return q + fade[:, None] * offset[None, :]


def action_target(action: Any, positions: Mapping[str, Sequence[float]]) -> Any:
    """Where a command's arms go when nothing says better: the last object its action names
    (an agent is not one), as ``(x, y, z)``; None when it names none."""
    objs = [a for a in action.args if a in positions and a not in action.agents]
    if not objs:
        return None
    x, y, z = (float(v) for v in positions[objs[-1]])
    return (x, y, z)


def command_path(
    execution: Any,
    action: Any,
    *,
    since: int,
    start: Mapping[str, np.ndarray],
    duration: float,
    positions: Mapping[str, Sequence[float]],
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The joint path ``(t, {arm: q})`` of ``action`` for each arm of the robot model it names,
    from 0 to ``duration``. ``execution`` is the arm's
    :class:`~flexhrc.action.bridge.KinematicTaskSimulator`; ``since`` the length of its
    execution log before the command ran; ``start`` every arm's joints before it. A nominal
    path moves the model's arms to its end (they are there now)."""
    em = execution.execution
    arms = [a for a in action.agents if a in em.sim.robot.arm_names]
    ran = em.joint_path(since)
    if ran is not None and all(a in ran[1] for a in arms):
        t, q = ran
        return fit_duration(t, {a: q[a] for a in arms}, duration)
    path = _nominal_path(em, arms, start, action_target(action, positions), duration)
    for a, qa in path[1].items():
        em.state.q[a] = qa[-1].copy()
    return path


def _nominal_path(
    em: Any,
    arms: list[str],
    start: Mapping[str, np.ndarray],
    target: Any,
    duration: float,
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    stay = np.zeros(1), {a: np.asarray(start[a], dtype=float)[None, :] for a in arms}
    if target is None or not arms or duration <= 0:
        return fit_duration(*stay, duration)
    from flexhrc.action.simulator import RobotState

    state = RobotState({a: np.asarray(v, dtype=float) for a, v in start.items()},
                       dict(em.state.holding))  # fmt: skip
    who = arms[0] if len(arms) == 1 else "both"
    try:
        out = em.sim.simulate(
            who, "approach", target, start=state, obstacles=em.obstacles,
            human_hand=em.human_hand, record=True,
        )  # fmt: skip
    except Exception:  # an action the model cannot aim at: the arm stays (never a crash)
        return fit_duration(*stay, duration)
    traj = out.trajectory
    if len(traj) < 2 or not all(a in traj.arms for a in arms):
        return fit_duration(*stay, duration)
    src_t = np.asarray(traj.t, dtype=float) - float(traj.t[0])
    tau = np.linspace(0.0, 1.0, NOMINAL_SAMPLES)
    warped = min_jerk(tau) * float(src_t[-1])
    q = {
        a: np.column_stack(
            [np.interp(warped, src_t, traj.arm_q(a)[:, j]) for j in range(traj.arm_q(a).shape[1])]
        )
        for a in arms
    }
    for a in arms:
        q[a][0] = np.asarray(start[a], dtype=float)
    return fit_duration(tau * duration, q, duration)
