"""Robot Execution Manager: commands on the simulated real robot, disturbances, reports."""

from __future__ import annotations

import pytest

from flexhrc.action.execution import Command, Disturbance, ExecutionManager
from flexhrc.errors import FlexhrcError, UnknownNameError

LEG = (0.45, 0.1, 0.05)
PLACE = (0.6, -0.1, 0.15)


def _manager(sim):
    return ExecutionManager(sim, objects={"leg1": LEG, "leg2": (0.5, -0.1, 0.05)})


def _pick_and_place(em, obj="leg1", pick=LEG, arm="left"):
    return [
        em.execute(Command("approach", arm, pick, obj)),
        em.execute(Command("grasp", arm, pick, obj)),
        em.execute(Command("transport", arm, PLACE, obj)),
        em.execute(Command("ungrasp", arm)),
        em.execute(Command("rest", arm)),
    ]


def test_undisturbed_commands_are_done_and_move_the_object(sim):
    em = _manager(sim)
    reports = _pick_and_place(em)
    assert [r.status for r in reports] == ["done"] * 5
    assert em.objects["leg1"].position == pytest.approx(PLACE, abs=1e-3)
    assert em.time_s == pytest.approx(sum(r.duration_s for r in reports))
    assert all(r.expected_s == pytest.approx(r.duration_s) for r in reports)  # nominal world
    assert reports[0].to_dict()["status"] == "done"


def test_moved_object_makes_the_grasp_fail_and_is_reported(sim):
    em = _manager(sim)
    em.inject(Disturbance("object_moved", object="leg1", offset=(0.0, 0.08, 0.0)))
    r = em.execute(Command("approach", "left", LEG, "leg1"))
    assert r.status == "failed" and "not where expected" in r.reason
    assert r.observed["position"] == pytest.approx([0.45, 0.18, 0.05])
    # Re-planning with the observed pose succeeds.
    new = tuple(r.observed["position"])
    assert [x.status for x in _pick_and_place(em, pick=new)] == ["done"] * 5


def test_slow_arm_times_out_then_recovers(sim):
    em = _manager(sim)
    em.inject(Disturbance("slow_arm", arm="left", factor=0.2, once=True))
    r = em.execute(Command("approach", "left", LEG, "leg1"))
    assert r.status == "timed_out" and "no acknowledgement" in r.reason
    assert r.duration_s == pytest.approx(r.timeout_s, abs=0.05)
    assert r.disturbances and "slowed" in r.disturbances[0]
    # The other arm was not affected; once=True: the left arm is back to speed afterwards.
    assert em.execute(Command("approach", "right", (0.5, -0.1, 0.05), "leg2")).status == "done"
    assert em.execute(Command("approach", "left", LEG, "leg1")).status == "done"


def test_blocked_path_fails_with_the_reason(sim):
    em = _manager(sim)
    # An unknown box right over the leg: the hand cannot get within reach of it.
    em.inject(Disturbance("blocked_path", obstacle=[0.45, 0.1, 0.15, 0.05, 0.05, 0.05]))
    r = em.execute(Command("approach", "left", LEG, "leg1"))
    assert r.status in ("failed", "timed_out") and "obstacle" in r.reason


def test_bad_commands_and_disturbances_are_named(sim):
    em = _manager(sim)
    with pytest.raises(UnknownNameError, match="argument 'arm'"):
        em.execute(Command("approach", "middle", LEG))
    with pytest.raises(UnknownNameError, match="argument 'action'"):
        em.execute(Command("dance", "left", LEG))
    with pytest.raises(FlexhrcError, match="target"):
        em.execute({"action": "grasp", "arm": "left", "target": [1, 2]})
    with pytest.raises(UnknownNameError, match="unknown disturbance"):
        Disturbance("earthquake")
    with pytest.raises(UnknownNameError, match="unknown object"):
        em.inject({"kind": "object_moved", "object": "leg9", "offset": (0, 0, 0)})
    with pytest.raises(FlexhrcError, match="factor"):
        Disturbance("slow_arm", arm="left", factor=0.0)


def test_disturbances_during_execution(sim):
    em = _manager(sim)
    # The leg is moved while the arm is on its way: the approach ends where it was, and fails.
    em.inject(Disturbance("object_moved", object="leg1", offset=(0.05, 0.0, 0.0), at_s=0.5))
    assert em.objects["leg1"].position == LEG  # not yet
    r = em.execute(Command("approach", "left", LEG, "leg1"))
    assert r.status == "failed" and "not where expected" in r.reason
    assert any("at 0.5 s" in d for d in r.disturbances)
    assert em.objects["leg1"].position == pytest.approx((0.5, 0.1, 0.05))
    # The arm slows down half-way through an approach: no acknowledgement in time.
    em.inject(Disturbance("slow_arm", arm="right", factor=0.1, at_s=0.3, once=True))
    r = em.execute(Command("approach", "right", (0.5, -0.1, 0.05), "leg2"))
    assert r.status == "timed_out"
    # An obstacle appears over the leg during the approach: the arm keeps away, and fails.
    em.inject(Disturbance("blocked_path", obstacle=[0.5, 0.1, 0.15, 0.04], at_s=0.2))
    r = em.execute(Command("approach", "left", (0.5, 0.1, 0.05), "leg1"))
    assert r.status in ("failed", "timed_out") and "obstacle" in r.reason
    with pytest.raises(FlexhrcError, match="at_s"):
        Disturbance("slow_arm", arm="left", factor=0.5, at_s=-1.0)


def test_joint_path_is_the_commands_motion_from_their_start_to_their_total_duration(sim):
    em = _manager(sim)
    start = {a: q.copy() for a, q in em.state.q.items()}
    assert em.joint_path() is None  # nothing ran yet
    reports = _pick_and_place(em)  # approach, grasp (closes after), transport, ungrasp, rest
    t, q = em.joint_path()
    assert t[0] == 0.0 and all(t[1:] > t[:-1])
    assert t[-1] == pytest.approx(sum(r.duration_s for r in reports))
    assert list(q) == ["left"] and q["left"].shape == (len(t), 7)
    assert abs(q["left"][0] - start["left"]).max() == 0.0
    assert abs(q["left"][-1] - em.state.q["left"]).max() == pytest.approx(0.0, abs=1e-12)
    # the gripper closes after the grasp's motion: the arm stands still meanwhile
    moved = reports[0].duration_s + float(reports[1].outcome.trajectory.t[-1])
    closed = reports[0].duration_s + reports[1].duration_s
    assert closed - moved == pytest.approx(sim.actions["grasp"].gripper_time_s)
    held = q["left"][(t >= moved - 1e-9) & (t <= closed + 1e-9)]
    assert len(held) >= 2 and abs(held - held[0]).max() == 0.0
    # from a later command on: only its own motion, from 0
    n = len(em.log)
    em.execute(Command("approach", "left", LEG))
    t2, q2 = em.joint_path(n)
    assert t2[0] == 0.0 and t2[-1] == pytest.approx(em.log[-1].duration_s)
    assert abs(q2["left"][0] - q["left"][-1]).max() == 0.0
