"""Branch simulations that share their work (issue 23, item 3): the old path and the new give the
same decisions; the lockstep integrator — the compiled loop (numba) and the numpy one — gives the
scalar one's outcomes; the motion cache is keyed on the moving arm only."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("pinocchio")

from flexhrc.action import KinematicTaskSimulator, kernel
from flexhrc.action import batch as batch_module
from flexhrc.action.batch import MotionRequest, motion_key, simulate_many
from flexhrc.action.simulator import KinematicSimulator, RobotState
from flexhrc.cell.local import LocalCell
from flexhrc.scenario import load_scenario
from flexhrc.scenario.builtin.table import table_assembly
from flexhrc.taskmanager import AnalyticSimulator, TaskManager
from flexhrc.taskmanager.decision import DecisionTree

GEARBOX = Path(__file__).resolve().parents[2] / "examples" / "scenarios" / "gearbox.yaml"

#: the two ways lanes are integrated: compiled (where numba is installed) and numpy
INTEGRATORS = [
    pytest.param(True, id="compiled", marks=pytest.mark.skipif(
        not kernel.available(), reason="numba is not installed")),
    pytest.param(False, id="numpy"),
]  # fmt: skip


@pytest.fixture
def integrator(request: Any, monkeypatch: pytest.MonkeyPatch) -> Any:
    """Lanes integrated by the compiled loop or by the numpy lockstep; counts the compiled
    lanes so a test can check the loop it asked for ran."""
    compiled = bool(request.param)
    monkeypatch.setattr(kernel, "enabled", compiled)
    calls = {"n": 0}
    real = kernel.integrate

    def counted(*args: Any) -> Any:
        calls["n"] += 1
        return real(*args)

    monkeypatch.setattr(kernel, "integrate", counted)
    yield calls if compiled else None
    if compiled:
        assert calls["n"] > 0, "the compiled loop never ran"
    else:
        assert calls["n"] == 0


def decisions(scenario: Any, share: bool, **kw: Any) -> tuple[list[dict[str, Any]], Any]:
    kin = KinematicTaskSimulator(share=share)
    result = LocalCell(scenario, simulator=kin, execution=kin, **kw).run()
    return [e for e in result.events if e["type"] == "decision"], kin


def assert_same_decisions(old: list[dict[str, Any]], new: list[dict[str, Any]]) -> None:
    assert len(old) == len(new) and old
    for a, b in zip(old, new, strict=True):
        assert a["element"] == b["element"]
        assert a.get("chosen") == b.get("chosen")
        assert len(a["branches"]) == len(b["branches"])
        best_a = max(a["branches"], key=lambda x: x["utility"])
        best_b = max(b["branches"], key=lambda x: x["utility"])
        assert best_a["grounding"] == best_b["grounding"]
        for x, y in zip(a["branches"], b["branches"], strict=True):
            assert x["grounding"] == y["grounding"] and x["success"] == y["success"]
            assert x["reason"] == y["reason"]
            assert abs(x["utility"] - y["utility"]) <= 1e-6
            assert np.allclose(x["durations"], y["durations"], rtol=0, atol=1e-6)


@pytest.mark.parametrize("profile", ["passive", "cooperative"])
def test_the_table_decides_the_same_with_shared_branches(profile):
    sc = table_assembly(4, seed=2, segments="legs")
    old, kin_old = decisions(sc, False, profile=profile, seed=2)
    new, kin_new = decisions(table_assembly(4, seed=2, segments="legs"), True, profile=profile,
                             seed=2)  # fmt: skip
    assert_same_decisions(old, new)
    assert sum(len(d["branches"]) for d in new) >= 8
    # the motions of later decisions come from the cache (the arm that did not move)
    assert kin_new.motions_integrated < kin_old.motions_integrated
    assert kin_new.steps_integrated < kin_old.steps_integrated


def test_a_scenario_of_motion_kinds_decides_the_same_with_shared_branches():
    old, _ = decisions(load_scenario(GEARBOX), False)
    new, _ = decisions(load_scenario(GEARBOX), True)
    assert_same_decisions(old, new)


def first_tree(simulator: Any) -> DecisionTree:
    """The first decision tree of the 4-leg table (seed 0), evaluated by ``simulator``."""
    sc = table_assembly(4, seed=0, segments="legs")
    tm = TaskManager(sc.online_graph(), sc.domain, sc.world(), simulator)
    trees: list[DecisionTree] = []
    build = tm._tree

    def keep(*args: Any, **kw: Any) -> DecisionTree:
        trees.append(build(*args, **kw))
        return trees[-1]

    tm._tree = keep  # type: ignore[method-assign]
    tm.start(0.0)
    return trees[0]


@pytest.mark.parametrize("integrator", INTEGRATORS, indirect=True)
def test_the_first_decision_of_the_table_old_and_new(integrator):
    kin_old = KinematicTaskSimulator(KinematicSimulator(dt=0.04, cache_size=0), share=False)
    kin_new = KinematicTaskSimulator(KinematicSimulator(dt=0.04, cache_size=0), share=True)
    a, b = first_tree(kin_old), first_tree(kin_new)
    assert len(a.branches) == len(b.branches) == 8
    for x, y in zip(a.branches, b.branches, strict=True):
        assert x.grounding == y.grounding
        assert x.result.success and y.result.success
        assert abs(x.utility - y.utility) <= 1e-6
        assert len(x.result.details) == len(y.result.details)
        for d1, d2 in zip(x.result.details, y.result.details, strict=True):
            assert d1.keys() == d2.keys() and d1.get("paths") == d2.get("paths")
            for k in ("t", "energy", "min_distance_m"):
                assert d1[k] == pytest.approx(d2[k], rel=1e-9, abs=1e-4 if k == "energy" else 1e-9)
    best = max(a.branches, key=lambda br: br.utility)
    assert best.grounding == max(b.branches, key=lambda br: br.utility).grounding
    assert kin_old.steps_integrated == kin_new.steps_integrated  # nothing repeats in it
    assert kin_new.simulated == kin_old.simulated
    assert list(kin_new.simulated) == list(kin_old.simulated)


def _requests(sim: KinematicSimulator) -> list[MotionRequest]:
    rest = sim.rest_state()
    moved = rest.copy()
    moved.q["left"] = moved.q["left"] + np.array([0.3, -0.2, 0.1, 0.2, 0.1, 0.3, -0.4])
    moved.holding["right"] = True
    hand = (0.45, 0.25, 0.12)  # close to the left arm's paths: the human-hand row is active
    ball = (0.5, -0.25, 0.12, 0.04)  # an obstacle on the right arm's way
    reqs = []
    for arm in ("left", "right"):
        for target in [(0.45, 0.3, 0.02), (0.5, -0.3, 0.02), (0.62, 0.05, 0.1), (0.4, 0.0, 0.3)]:
            reqs.append(MotionRequest(arm, "approach", target, rest, (ball,), hand))
            reqs.append(MotionRequest(arm, "transport", target, moved, (ball,), hand))
        reqs.append(MotionRequest(arm, "grasp", None, moved, (), hand))
        reqs.append(MotionRequest(arm, "screw", (0.56, 0.16, 0.1), moved, (), None))
        reqs.append(MotionRequest(arm, "ungrasp", None, moved, (ball,), hand))
        reqs.append(MotionRequest(arm, "rest", None, moved, (ball,), hand))
        reqs.append(MotionRequest(arm, "insert", (0.5, 0.0, 0.1), moved, (), None))
        reqs.append(MotionRequest(arm, "approach", (1.6, 0.0, 0.1), rest, (), None))  # too far
        # straight into an obstacle on the target: stalls (the reason is diagnosed)
        reqs.append(MotionRequest(arm, "transport", (0.5, 0.0, 0.1), moved,
                                  ((0.5, 0.0, 0.1, 0.05),), None))  # fmt: skip
    # joints starting inside their limits' transition zones: the joint-limit rows are active
    near = rest.copy()
    for arm in ("left", "right"):
        model = sim.robot.arm(arm)
        near.q[arm] = near.q[arm].copy()
        near.q[arm][0] = model.q_min[0] + 0.06
        near.q[arm][3] = model.q_max[3] - 0.05
        near.q[arm][5] = model.q_max[5] - 0.07
        for target in [(0.45, 0.3, 0.02), (0.5, -0.3, 0.02)]:
            reqs.append(MotionRequest(arm, "approach", target, near, (ball, (0.45, 0.3, 0.1, 0.03)),
                                      hand))  # fmt: skip
        reqs.append(MotionRequest(arm, "rest", None, near, (), hand))
        # two obstacles, one just above the goal: both of their rows and the hand's
        two = (ball, (0.47, 0.3, 0.17, 0.03))
        reqs.append(MotionRequest(arm, "approach", (0.45, 0.3, 0.02), rest, two, hand))
    reqs.append(MotionRequest("both", "rest", None, moved, (), None))  # two arms: scalar
    return reqs


@pytest.mark.parametrize("integrator", INTEGRATORS, indirect=True)
def test_lockstep_outcomes_are_the_scalar_integrators(integrator):
    sim = KinematicSimulator(dt=0.04, cache_size=0)
    reqs = _requests(sim)
    together = simulate_many(sim, reqs)
    for r, out in zip(reqs, together, strict=True):
        ref = sim.simulate(
            r.arm, r.action, r.target, start=r.start, obstacles=r.obstacles,
            human_hand=r.human_hand, record=False,
        )  # fmt: skip
        assert (out.action, out.arm, out.success, out.steps) == (
            ref.action, ref.arm, ref.success, ref.steps,
        ), (r, out.reason, ref.reason)  # fmt: skip
        assert out.reason == ref.reason
        assert out.duration_s == pytest.approx(ref.duration_s, abs=1e-9)
        assert out.energy == pytest.approx(ref.energy, rel=1e-9, abs=1e-12)
        assert out.min_distance_m == pytest.approx(ref.min_distance_m, abs=1e-9)
        assert out.final_error_m == pytest.approx(ref.final_error_m, abs=1e-9)
        for a in ref.final_state.q:
            assert np.allclose(out.final_state.q[a], ref.final_state.q[a], rtol=0, atol=1e-9)
        assert out.final_state.holding == ref.final_state.holding
    assert {o.success for o in together} == {True, False}
    assert any("stalled" in o.reason for o in together)
    assert any(0.0 < o.min_distance_m < 0.2 for o in together)  # a minimum distance was active


def test_the_compiled_loop_is_the_numpy_lockstep_step_by_step(monkeypatch):
    """Both integrators of a lane give the same outcome and the same TCP path, point by point."""
    if not kernel.available():
        pytest.skip("numba is not installed")
    sim = KinematicSimulator(dt=0.04, cache_size=0)
    reqs = _requests(sim)
    runs = {}
    for compiled in (True, False):
        monkeypatch.setattr(kernel, "enabled", compiled)
        paths: list[Any] = []
        runs[compiled] = (simulate_many(sim, reqs, paths), paths)
    (a, pa), (b, pb) = runs[True], runs[False]
    lanes = 0
    for x, y, px, py in zip(a, b, pa, pb, strict=True):
        assert (x.success, x.steps, x.reason) == (y.success, y.steps, y.reason)
        assert x.duration_s == pytest.approx(y.duration_s, abs=1e-9)
        if px is not None:
            lanes += 1
            assert px.shape == py.shape and np.allclose(px, py, rtol=0, atol=1e-9)
    assert lanes >= len(reqs) - 6  # all but the two-arm, too-far and unsupported requests


def test_the_kernel_refuses_what_it_cannot_integrate():
    """A chain that is not revolute joints about principal axes, or an objective the kernel
    does not know, is left to the numpy lockstep (None), never integrated wrongly."""

    class Joint:
        def __init__(self, name: str):
            self.name, self.idx_q = name, 0

        def shortname(self) -> str:
            return self.name

    from types import SimpleNamespace

    model = SimpleNamespace(
        nq=1, nv=1, njoints=2, parents=[0, 0],
        joints=[Joint("JointModelRZ"), Joint("JointModelPZ")],  # a prismatic joint
        frames=[SimpleNamespace(parentJoint=1)],
    )  # fmt: skip
    assert kernel.chain_of(SimpleNamespace(model=model, tcp_frame=0)) is None
    assert kernel.objectives_of(SimpleNamespace(n=7, levels=[[object()]])) is None


def test_without_numba_the_numpy_lockstep_runs(tmp_path):
    """FLEXHRC_JIT=0 (as without numba): the kernel is not available and a decision is still
    simulated, by the numpy lockstep."""
    import subprocess
    import sys

    code = (
        "from flexhrc.action import kernel, lockstep\n"
        "from flexhrc.action.batch import MotionRequest, simulate_many\n"
        "from flexhrc.action.simulator import KinematicSimulator\n"
        "assert not kernel.available()\n"
        "sim = KinematicSimulator(dt=0.04, cache_size=0)\n"
        "r = MotionRequest('left', 'approach', (0.45, 0.3, 0.02), sim.rest_state())\n"
        "out = simulate_many(sim, [r])\n"
        "assert out[0].success, out[0].reason\n"
        "print('ok', out[0].steps)\n"
    )
    env = dict(__import__("os").environ, FLEXHRC_JIT="0")
    done = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("ok ")


def test_lockstep_can_be_switched_off(monkeypatch):
    sim = KinematicSimulator(dt=0.04, cache_size=0)
    reqs = _requests(sim)[:3]
    on = simulate_many(sim, reqs)
    monkeypatch.setattr(batch_module, "lockstep_enabled", False)
    off = simulate_many(sim, reqs)
    assert [o.steps for o in on] == [o.steps for o in off]


def test_the_motion_key_is_the_moving_arms_not_the_others():
    sim = KinematicSimulator(dt=0.04, cache_size=0)
    rest = sim.rest_state()
    elsewhere = rest.copy()
    elsewhere.q["right"] = elsewhere.q["right"] + 0.2
    elsewhere.holding["right"] = True
    a = MotionRequest("left", "approach", (0.45, 0.3, 0.02), rest)
    b = MotionRequest("left", "approach", (0.45, 0.3, 0.02), elsewhere)
    assert motion_key(sim, a) == motion_key(sim, b)
    # what the controller reads is in it: the moving arm's joints, the world, the target
    moved = rest.copy()
    moved.q["left"] = moved.q["left"] + 1e-9
    for other in (
        MotionRequest("left", "approach", (0.45, 0.3, 0.02), moved),
        MotionRequest("left", "approach", (0.45, 0.3, 0.03), rest),
        MotionRequest("left", "grasp", (0.45, 0.3, 0.02), rest),
        MotionRequest("left", "approach", (0.45, 0.3, 0.02), rest, ((0.5, 0.0, 0.1, 0.05),)),
        MotionRequest("left", "approach", (0.45, 0.3, 0.02), rest, (), (0.4, 0.0, 0.1)),
        MotionRequest("both", "approach", (0.45, 0.3, 0.02), rest),
    ):
        assert motion_key(sim, other) != motion_key(sim, a)
    # both arms move: the other arm is part of it
    assert motion_key(sim, MotionRequest("both", "rest", None, rest)) != motion_key(
        sim, MotionRequest("both", "rest", None, elsewhere)
    )


def test_a_motion_is_integrated_once_and_rebased_on_each_start():
    kin = KinematicTaskSimulator(KinematicSimulator(dt=0.04, cache_size=0))
    rest: RobotState = kin.sim.rest_state()
    elsewhere = rest.copy()
    elsewhere.q["right"] = elsewhere.q["right"] + 0.2
    a = MotionRequest("left", "approach", (0.45, 0.3, 0.02), rest)
    b = MotionRequest("left", "approach", (0.45, 0.3, 0.02), elsewhere)
    out_a, out_b = kin._motions([a, b])
    assert kin.motions_requested == 2 and kin.motions_integrated == 1
    assert out_a.duration_s == out_b.duration_s
    assert np.array_equal(out_a.final_state.q["left"], out_b.final_state.q["left"])
    assert np.array_equal(out_b.final_state.q["right"], elsewhere.q["right"])  # its own
    assert np.array_equal(out_a.final_state.q["right"], rest.q["right"])
    kin._motions([b])  # across decisions: still cached
    assert kin.motions_integrated == 1


class _Counting(AnalyticSimulator):
    def __init__(self) -> None:
        super().__init__()
        self.many = 0

    def simulate_many(self, branches, kb, domain):
        self.many += 1
        return [self.simulate(s, kb, domain) for s in branches]


def test_decision_trees_use_simulate_many_when_offered_and_simulate_otherwise():
    counting = _Counting()
    a = first_tree(counting)
    assert counting.many == 1
    b = first_tree(AnalyticSimulator())
    assert len(a.branches) == 8
    assert [x.utility for x in a.branches] == [x.utility for x in b.branches]


def test_a_motion_far_from_the_hand_serves_the_hand_elsewhere_and_only_then():
    kin = KinematicTaskSimulator(KinematicSimulator(dt=0.04, cache_size=0))
    sim = kin.sim
    rest = sim.rest_state()
    target = (0.45, 0.3, 0.02)

    def fresh(hand):
        return sim.simulate("left", "approach", target, start=rest, human_hand=hand, record=False)

    kin._motions([MotionRequest("left", "approach", target, rest, (), (0.9, -0.5, 0.1))])
    assert kin.motions_integrated == 1
    for hand in [(0.2, -0.6, 0.3), None]:  # far from the whole path, or no hand at all
        (out,) = kin._motions([MotionRequest("left", "approach", target, rest, (), hand)])
        ref = fresh(hand)
        assert kin.motions_integrated == 1
        assert (out.steps, out.duration_s, out.reason) == (ref.steps, ref.duration_s, ref.reason)
        assert out.min_distance_m == pytest.approx(ref.min_distance_m, abs=1e-12)
        assert np.allclose(out.final_state.q["left"], ref.final_state.q["left"], rtol=0, atol=1e-9)
    assert kin.motions_far == 2
    # the hand right where the arm goes: its objective acts, the motion is integrated anew
    near = (0.45, 0.3, 0.14)
    (out,) = kin._motions([MotionRequest("left", "approach", target, rest, (), near)])
    ref = fresh(near)
    assert kin.motions_integrated == 2 and kin.motions_far == 2
    assert (out.steps, out.success, out.reason) == (ref.steps, ref.success, ref.reason)
