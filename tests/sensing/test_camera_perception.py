"""The perception component on rendered head-camera frames (issue 13, item 1)."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("pybullet")
pytest.importorskip("scipy")

from flexhrc.errors import FlexhrcError
from flexhrc.sensing.camera import HeadCamera
from flexhrc.sensing.loop import forget_positions
from flexhrc.sensing.perception import PerceptionComponent
from flexhrc.sensing.world import SimulatedWorkspace

from .conftest import table

PARTS = ("leg", "tabletop")


@pytest.fixture(scope="module")
def camera():
    cam = HeadCamera()
    yield cam
    cam.close()


def setup(camera, seed=0):
    _, truth = table(seed)
    world, names = SimulatedWorkspace.from_knowledge(truth, types=PARTS)
    belief = forget_positions(truth, PARTS)
    return truth, world, names, belief, PerceptionComponent(world, belief, camera=camera)


def test_no_position_is_given_and_one_frame_anchors_every_part(camera):
    _truth, world, names, belief, comp = setup(camera)
    assert not any(belief.object(o).anchored for o in names)
    upd = comp.update(0.0)
    assert set(upd.report.anchored) == set(names) and upd.report.new_objects == []
    assert belief.consistent
    # every symbol sits on one part, within 1.5 cm (the symbols are interchangeable legs)
    parts = [world.part(p) for p in names.values()]
    for sym in names:
        pos = belief.position(sym)
        d = min(
            math.dist(pos[:2], p.position[:2])
            for p in parts
            if belief.compatible(belief.object(sym).type, p.type)
        )
        assert d < 0.015, (sym, pos)


def test_the_robot_is_in_the_picture_but_filtered_out(camera):
    _, world, _, _, comp = setup(camera)
    upd = comp.update(0.0, rgb=True)
    frame = upd.frame
    assert frame is not None and frame.rgb is not None and frame.rgb.shape[2] == 3
    assert frame.robot_pixels > 100  # the torso and the arms are seen...
    assert not frame.depth[frame.robot_mask].any()  # ...and their depth removed
    assert len(upd.detections) == len(world.parts)  # no forearm taken for a part


def test_arms_in_another_posture_hide_parts_and_the_hidden_end_is_completed(camera):
    from flexhrc.action.robots import PANDA_Q_REST

    _, _world, names, belief, comp = setup(camera, seed=1)
    comp.update(0.0)
    before = {s: belief.position(s) for s in names}
    # an arm reaching over the table: whatever it hides, no symbol jumps, nothing is new
    q = list(PANDA_Q_REST)
    q[1] = 0.3
    comp.robot_q = lambda: {"left": q, "right": PANDA_Q_REST}
    upd = comp.update(1.0)
    assert upd.frame is None and upd.report.new_objects == [] and upd.report.moved == []
    for s in names:
        assert math.dist(before[s][:2], belief.position(s)[:2]) < 0.02


def test_screwed_legs_stand_upright_on_the_tabletop_and_are_still_seen(camera):
    truth, world, names, belief, comp = setup(camera)
    comp.update(0.0)
    board = names["tabletop"]
    for leg, bolt in (("leg1", "bolt_1"), ("leg2", "bolt_2")):
        part = world.grasp("left", world.part(names[leg]).position)
        assert part is not None
        world.attach("left", truth.position(bolt), on=board)
        sym = min(
            (s for s in names if s.startswith("leg")),
            key=lambda s: math.dist(belief.position(s)[:2], truth.position(leg)[:2]),
        )
        belief.move(sym, truth.position(bolt))  # what the manager predicts
        belief.set_fixed(sym)
    upd = comp.update(10.0)
    assert set(upd.report.anchored) == set(names), upd.to_dict()
    assert upd.report.inconsistencies == [] and upd.report.new_objects == []


def test_workspace_physics():
    _, truth = table()
    world, names = SimulatedWorkspace.from_knowledge(truth, types=PARTS)
    leg = world.part(names["leg1"])
    assert world.grasp("left", (9.0, 9.0)) is None  # nothing there
    assert world.grasp("left", leg.position).holder == "left"
    assert world.grasp("left", leg.position) is None  # the hand is full
    world.carry("left", (0.7, 0.0, 0.1))
    dropped = world.release("left")
    assert dropped.holder is None and dropped.position == pytest.approx((0.7, 0.0, 0.02))
    with pytest.raises(FlexhrcError, match="no part"):
        world.displace("nope", (0.1, 0))
    assert world.clear_at(dropped.name, (1.0, 0.6)) and not world.clear_at(
        dropped.name, world.part(names["tabletop"]).position[:2]
    )
    taken = world.pick_up("human", dropped.position)
    assert taken.holder == "human" and taken.position == world.hand
    assert world.put_down("human").position[2] == pytest.approx(0.02)


def test_camera_arguments_are_checked():
    with pytest.raises(ValueError, match="16x16"):
        HeadCamera(width=4)
    with pytest.raises(ValueError, match="hfov"):
        HeadCamera(hfov_deg=0.0)


def test_projection_of_the_table_centre_lands_in_the_image(camera):
    _, world, _, _, _comp = setup(camera)
    frame = camera.render(world)
    u, v = frame.project(np.array([[0.6, 0.0, 0.0]]))[0]
    assert 0 <= u < frame.intrinsics.width and 0 <= v < frame.intrinsics.height


def test_rods_are_laid_clear_of_each_other_and_crowded_ones_refused():
    from flexhrc.knowledge import KnowledgeBase

    kb = KnowledgeBase()
    # side by side 1 cm apart along y but 8 cm along x: lying along x they would overlap
    kb.add_object("a", "leg", (0.41, -0.43, 0.0), {"length": 0.4, "diameter": 0.04})
    kb.add_object("b", "leg", (0.49, -0.42, 0.0), {"length": 0.4, "diameter": 0.04})
    world, names = SimulatedWorkspace.from_knowledge(kb)
    yaws = {world.part(names[o]).yaw for o in ("a", "b")}
    assert yaws == {0.0} or math.pi / 2 in yaws  # one of them turned
    for o in ("a", "b"):
        assert world.clear_at(names[o], world.part(names[o]).position[:2], gap_m=0.005)
    kb.add_object("c", "leg", (0.45, -0.425, 0.0), {"length": 0.4, "diameter": 0.04})
    with pytest.raises(FlexhrcError, match="overlap"):
        SimulatedWorkspace.from_knowledge(kb)
