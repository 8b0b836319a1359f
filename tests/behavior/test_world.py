import math

import pytest

from flexhrc.behavior import Arm, MoveRule, TabletopWorld, ValidityCheck, WorldObject, random_world
from flexhrc.errors import FlexhrcError, UnknownNameError


def make_world(moves=()):
    return TabletopWorld(
        [
            WorldObject("cup", (0.5, 0.0, 0.75), (1.0, 0.0, 0.75)),
            WorldObject("fork", (0.5, 0.4, 0.75)),
        ],
        [Arm("arm", (0.0, 0.0, 0.75), speed=0.5)],
        moves,
        grasp_time=2.0,
        place_time=1.0,
    )


def test_pick_and_place_duration_follows_distance_and_speed():
    w = make_world()
    m = w.start_pick_and_place("arm", "cup", now=1.0)
    # reach 0.5 m + grasp 2 s + carry 0.5 m + place 1 s + return 1.0 m, at 0.5 m/s
    assert m.t_reach == pytest.approx(2.0)
    assert m.t_grasp == pytest.approx(4.0)
    assert m.t_end == pytest.approx(1.0 + 1.0 + 2.0 + 1.0 + 1.0 + 2.0)
    assert (
        m.phase_at(3.0) == "grasp" and m.phase_at(4.5) == "carry" and m.phase_at(8.0) == "finished"
    )
    w.step(4.5)
    assert w.objects["cup"].held_by == "arm"
    assert not w.object_in_view("cup")
    w.step(8.0)
    assert w.object_position("cup") == (1.0, 0.0, 0.75)
    assert w.arm_position("arm") == (0.0, 0.0, 0.75)
    assert w.arms["arm"].motion is None


def test_moves_at_a_time_and_during_a_grasp():
    w = make_world(
        [
            MoveRule("fork", (0.3, 0.3, 0.75), at=5.0),
            MoveRule("cup", (0.6, 0.2, 0.75), during_grasp=1.0),
        ]
    )
    assert w.step(4.9) == []
    assert [e["object"] for e in w.step(5.0)] == ["fork"]
    w.start_pick_and_place("arm", "cup", now=6.0)
    assert w.step(6.5) == []
    check = ValidityCheck.watch(w, "cup", threshold=0.05)
    assert check.valid(w)
    events = w.step(7.0)
    assert events == [
        {"kind": "move", "object": "cup", "from": [0.5, 0.0, 0.75], "to": [0.6, 0.2, 0.75]}
    ]
    assert not check.valid(w)
    assert check.displacement(w) == pytest.approx(math.hypot(0.1, 0.2))
    w.abort("arm", 7.0)
    assert w.arms["arm"].motion is None
    assert w.arm_position("arm") == pytest.approx((0.5, 0.0, 0.75))  # stopped at the old cup place
    assert w.step(10.0) == []  # each rule fires once


def test_errors_are_flexhrc_errors():
    with pytest.raises(UnknownNameError, match="unknown object 'spoon'"):
        make_world().object_position("spoon")
    with pytest.raises(FlexhrcError, match="exactly one"):
        MoveRule("cup", (0, 0, 0))
    with pytest.raises(FlexhrcError, match="at least one arm"):
        TabletopWorld([], [])


def test_random_world_is_seeded_and_inside_the_table_region():
    a = random_world(["x", "y", "z"], seed=3)
    b = random_world(["x", "y", "z"], seed=3)
    c = random_world(["x", "y", "z"], seed=4)
    assert a.snapshot() == b.snapshot() != c.snapshot()
    for o in a.objects.values():
        assert 0.35 <= o.position[0] <= 0.85 and -0.45 <= o.position[1] <= 0.45
    assert random_world(["x"], arms=2).arm_names == ["left", "right"]
