"""Simulator API for the Task Manager: outcomes, sequences, input errors, light import."""

from __future__ import annotations

import contextlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from flexhrc.action.simulator import ACTIONS, ActionSpec, KinematicSimulator, Pose
from flexhrc.errors import FlexhrcError, UnknownNameError


def test_import_of_the_action_level_is_light():
    code = (
        "import sys, flexhrc.action, flexhrc.action.simulator, flexhrc.action.execution;"
        "assert 'pinocchio' not in sys.modules and 'pybullet' not in sys.modules"
    )
    src = str(Path(__file__).resolve().parents[2] / "src")
    subprocess.run([sys.executable, "-c", code], check=True, env={**os.environ, "PYTHONPATH": src})


def test_outcome_fields_and_json(sim):
    out = sim.simulate("right", "approach", [0.5, -0.1, 0.05])
    assert out.success and out.reason == "goal reached"
    assert out.duration_s > 0 and out.energy > 0 and out.steps == len(out.trajectory) - 1
    assert set(out.final_q) == {"left", "right"}
    d = json.loads(json.dumps(out.to_dict(trajectory=True)))
    assert d["trajectory"]["tcp"]["right"][-1] == pytest.approx([0.5, -0.1, 0.15], abs=1e-3)


def test_sequence_chains_final_states_and_grasp_state(sim):
    seq = sim.pick_and_place("left", [0.4, 0.1, 0.05], [0.6, -0.15, 0.2])
    assert seq.success, seq.reason
    assert [o.action for o in seq.outcomes] == ["approach", "grasp", "transport", "ungrasp", "rest"]
    for prev, nxt in zip(seq.outcomes, seq.outcomes[1:], strict=False):
        np.testing.assert_allclose(nxt.trajectory.arm_q("left")[0], prev.final_q["left"])
    assert seq.outcomes[1].final_state.holding["left"] is True
    assert seq.outcomes[3].final_state.holding["left"] is False
    assert seq.duration_s == pytest.approx(sum(o.duration_s for o in seq.outcomes))
    np.testing.assert_allclose(seq.final_state.q["left"], sim.robot.arm("left").q_rest, atol=0.011)
    traj = seq.trajectory()
    assert np.all(np.diff(traj.t) >= 0) and len(traj) == sum(
        len(o.trajectory) for o in seq.outcomes
    )


def test_sequence_stops_at_the_first_failure(sim):
    seq = sim.simulate_sequence("left", [("approach", [1.5, 0, 0.1]), ("grasp", [1.5, 0, 0.1])])
    assert not seq.success and len(seq.outcomes) == 1 and seq.reason.startswith("approach:")


def test_hand_over_goes_to_the_middle_pose_by_default(sim):
    out = sim.simulate("right", "hand_over")
    assert out.success and out.trajectory.tcp["right"][-1] == pytest.approx(
        [0.55, 0, 0.3], abs=1e-3
    )


def test_screw_turns_the_hand(sim):
    out = sim.simulate("left", "screw", [0.5, 0.1, 0.15])
    assert out.success, out.reason
    q0, q1 = out.trajectory.arm_q("left")[0], out.final_q["left"]
    assert abs((q1 - q0)[6]) > 1.0  # mostly the last joint turns


def test_priorities_are_data_the_action_can_set():
    # A hierarchy where the end-effector goal outranks obstacle avoidance goes straight through.
    sim = KinematicSimulator()
    start = sim.simulate("left", "approach", [0.4, 0.15, 0.1]).final_state
    obstacle = [0.5, 0.05, 0.2, 0.04]
    reckless = ACTIONS["transport"].with_priorities(ee_position=0, ee_orientation=0)
    safe = sim.simulate("left", "transport", [0.6, -0.05, 0.2], start=start, obstacles=[obstacle])
    bold = sim.simulate("left", reckless, [0.6, -0.05, 0.2], start=start, obstacles=[obstacle])
    assert safe.min_distance_m >= 0.049 and bold.min_distance_m < 0.0
    custom = KinematicSimulator(actions={"lift": ActionSpec("lift", goal="retreat")})
    assert custom.simulate("left", "lift").success


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"arm": "centre", "action": "approach", "target": [0.5, 0, 0.1]}, UnknownNameError,
         "argument 'arm'"),
        ({"arm": "left", "action": "fly", "target": [0.5, 0, 0.1]}, UnknownNameError,
         "argument 'action'"),
        ({"arm": "left", "action": "approach", "target": [0.5, 0]}, FlexhrcError, "3 "),
        ({"arm": "left", "action": "approach", "target": "0.5 0 0.1"}, FlexhrcError, "3 "),
        ({"arm": "left", "action": "approach"}, FlexhrcError, "needs a target"),
        ({"arm": "left", "action": "approach", "target": [0.5, 0, 0.1], "obstacles": [[1, 2]]},
         FlexhrcError, "obstacle 1"),
        ({"arm": "left", "action": "approach", "target": [0.5, 0, 0.1], "human_hand": [1]},
         FlexhrcError, "human_hand"),
    ],
)  # fmt: skip
def test_bad_input_names_the_argument(sim, kwargs, error, message):
    with pytest.raises(error, match=message):
        sim.simulate(**kwargs)


def test_pose_coercion():
    assert Pose.coerce({"position": [1, 2, 3], "yaw": 0.5}) == Pose((1.0, 2.0, 3.0), 0.5)
    with pytest.raises(FlexhrcError, match="finite"):
        Pose.coerce([1, 2, float("nan")])


def test_gif_view(sim, tmp_path):
    pytest.importorskip("pybullet")
    from flexhrc.action.view import render

    out = sim.simulate("both", "approach", [0.5, 0.0, 0.1])
    gif = render(out.trajectory, tmp_path / "a.gif", max_frames=3, width=160, height=120)
    assert gif.read_bytes()[:6] == b"GIF89a"


def test_action_definition_round_trips_through_data(sim):
    spec = ACTIONS["hand_over"].with_params("ee_position", max_speed=0.2)
    again = ActionSpec.from_dict(json.loads(json.dumps(spec.to_dict())))
    assert again == spec
    custom = ActionSpec.from_dict(
        {
            "name": "place_carefully",
            "goal": "target",
            "hierarchy": [
                {"kind": "joint_limits", "priority": 0},
                {"kind": "obstacles", "priority": 1, "params": {"d_min": 0.1}},
                {"kind": "ee_position", "priority": 2, "params": {"max_speed": 0.1}},
            ],
        }
    )
    out = sim.simulate("left", custom, [0.5, 0.1, 0.2])
    assert (
        out.success
        and out.duration_s > sim.simulate("left", "transport", [0.5, 0.1, 0.2]).duration_s
    )
    with pytest.raises(FlexhrcError, match="unknown keys"):
        ActionSpec.from_dict({"name": "x", "colour": "red"})
    with pytest.raises(UnknownNameError, match="unknown objective kind"):
        ActionSpec.from_dict({"name": "x", "hierarchy": [{"kind": "fly", "priority": 0}]})


def test_lazy_package_exports():
    import flexhrc.action as action

    assert action.KinematicSimulator is KinematicSimulator
    with pytest.raises(AttributeError):
        _ = action.Nope


def test_grasp_and_screw_without_target_act_where_the_hand_is(sim):
    seq = sim.simulate_sequence(
        "left", [("approach", [0.5, 0.1, 0.05]), ("grasp", None), ("screw", None)]
    )
    assert seq.success, seq.reason
    grasp, screw = seq.outcomes[1], seq.outcomes[2]
    assert grasp.trajectory.tcp["left"][-1] == pytest.approx([0.5, 0.1, 0.05], abs=1e-3)
    assert screw.trajectory.tcp["left"][-1] == pytest.approx([0.5, 0.1, 0.05], abs=1e-3)
    with pytest.raises(FlexhrcError, match="needs a target"):
        sim.simulate("left", "transport")


def test_events_change_the_world_during_an_action(sim):
    from flexhrc.action.simulator import SimEvent

    free = sim.simulate("left", "transport", [0.5, 0.1, 0.2])
    slowed = sim.simulate(
        "left", "transport", [0.5, 0.1, 0.2], events=[SimEvent(0.2, velocity_scale=0.5)]
    )
    assert slowed.success and slowed.duration_s > free.duration_s
    blocked = sim.simulate(
        "left", "transport", [0.5, 0.1, 0.2], events=[SimEvent(0.2, obstacle=[0.5, 0.1, 0.2, 0.03])]
    )
    assert not blocked.success and "obstacle" in blocked.reason
    np.testing.assert_array_equal(blocked.trajectory.q[:10], free.trajectory.q[:10])


def test_outcome_cache_returns_copies_of_identical_requests():
    sim = KinematicSimulator(cache_size=2)
    a = sim.simulate("left", "transport", [0.5, 0.1, 0.2])
    b = sim.simulate("left", "transport", np.array([0.5, 0.1, 0.2]))
    assert b.wall_s == 0.0 and b.duration_s == a.duration_s
    b.final_state.q["left"][:] = 0.0  # callers may modify their copy
    c = sim.simulate("left", "transport", (0.5, 0.1, 0.2))
    np.testing.assert_array_equal(c.final_q["left"], a.final_q["left"])
    d = sim.simulate("left", "transport", [0.5, 0.1, 0.2 + 1e-9])  # another request
    assert d.wall_s > 0.0


def test_any_junk_target_or_obstacle_is_a_flexhrc_error():
    from hypothesis import given, settings
    from hypothesis import strategies as st

    from flexhrc.action.control import parse_obstacle

    junk = st.one_of(
        st.none(),
        st.text(max_size=5),
        st.floats(allow_nan=True, allow_infinity=True),
        st.lists(st.one_of(st.floats(), st.text(max_size=3), st.none()), max_size=8),
        st.dictionaries(st.sampled_from(["type", "center", "radius", "position", "yaw"]),
                        st.one_of(st.text(max_size=4), st.floats(), st.lists(st.floats()))),
    )  # fmt: skip

    @settings(max_examples=300, deadline=None)
    @given(junk)
    def check(value):
        for parse in (Pose.coerce, parse_obstacle):
            with contextlib.suppress(FlexhrcError):  # anything else fails the test
                parse(value)

    check()
