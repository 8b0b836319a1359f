"""Anchoring percepts to knowledge-base symbols (issue 13, item 2), without a renderer."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("scipy")

from flexhrc.knowledge import KnowledgeBase
from flexhrc.perception.scene.anchoring import Anchoring
from flexhrc.perception.scene.types import DetectedObject

LEG = {"length": 0.4, "diameter": 0.04}


def det(i: int, type: str, x: float, y: float, length: float = 0.4) -> DetectedObject:
    return DetectedObject(
        id=f"c{i}",
        type=type,
        position=np.array([x, y, 0.02]),
        orientation=np.array([0.0, 0.0, 0.0, 1.0]),
        axis=np.array([1.0, 0.0, 0.0]),
        size=np.array([length, 0.04, 0.04]),
        confidence=0.9,
        primitive="cylinder",
    )


def base() -> KnowledgeBase:
    kb = KnowledgeBase(supertypes={"leg_long": "leg"})
    kb.add_object("leg1", "leg", (0.3, 0.3, 0.02), LEG)
    kb.add_object("leg2", "leg", (0.3, -0.3, 0.02), LEG)
    kb.add_object("tabletop", "tabletop", (0.45, 0.0, 0.015), {"width": 0.3, "depth": 0.4})
    return kb


def test_gated_assignment_by_type_and_position_with_supertypes():
    kb = base()
    a = Anchoring(kb, ["leg_long", "tabletop"])
    # percepts of the subtype, listed in the other order and a little off
    rep = a.update([det(0, "leg_long", 0.31, -0.29), det(1, "leg_long", 0.29, 0.31)], 0.0)
    assert rep.anchored == {"leg2": "c0", "leg1": "c1"}
    assert kb.position("leg1")[:2] == pytest.approx((0.29, 0.31))
    assert kb.object("leg1").type == "leg"  # the symbol keeps its type
    assert rep.new_objects == [] and rep.inconsistencies == [] and kb.consistent


def test_symbols_known_without_a_position_are_anchored_by_type():
    kb = KnowledgeBase()
    kb.add_symbol("leg1", "leg", LEG)
    kb.add_symbol("top", "tabletop")
    assert not kb.object("leg1").anchored
    rep = Anchoring(kb, ["leg", "tabletop"]).update(
        [det(0, "tabletop", 0.45, 0.0), det(1, "leg", 0.5, 0.4)], 0.0
    )
    assert rep.anchored == {"top": "c0", "leg1": "c1"}
    assert kb.object("leg1").anchored and kb.position("leg1")[:2] == pytest.approx((0.5, 0.4))


def test_unmatched_percepts_become_new_objects_with_stable_names():
    kb = base()
    a = Anchoring(kb, ["leg"])
    first = a.update(
        [det(0, "leg", 0.3, 0.3), det(1, "leg", 0.3, -0.3), det(2, "leg", 0.8, 0.0)], 0
    )
    assert first.new_objects == ["leg_1"]
    assert kb.holds("leg", "leg_1")
    # next frame, the same three legs in another order: the new one keeps its name
    second = a.update(
        [det(0, "leg", 0.8, 0.01), det(1, "leg", 0.3, -0.3), det(2, "leg", 0.3, 0.3)], 1
    )
    assert second.new_objects == [] and second.anchored["leg_1"] == "c0"


def test_unknown_percepts_are_ignored():
    kb = base()
    rep = Anchoring(kb, ["leg"]).update([det(0, "unknown", 0.6, 0.0), det(1, "cone", 0.7, 0)], 0)
    assert rep.ignored == 2 and rep.new_objects == [] and rep.anchored == {}


def test_symbols_not_seen_for_n_frames_are_reported_missing_once():
    kb = base()
    a = Anchoring(kb, ["leg"], missing_after=3)
    seen = [det(0, "leg", 0.3, 0.3)]
    reports = [a.update(seen, float(t)) for t in range(4)]
    assert [r.missing for r in reports] == [[], [], ["leg2"], []]
    a.update([*seen, det(1, "leg", 0.3, -0.3)], 5.0)  # back: it may be reported again later
    assert "leg2" not in a.reported_missing


def test_a_jump_no_agent_could_make_is_an_inconsistency_a_later_compatible_percept_clears():
    kb = base()
    a = Anchoring(kb, ["leg"], max_speed_m_s=1.5)
    a.update([det(0, "leg", 0.3, 0.3), det(1, "leg", 0.3, -0.3)], 0.0)
    # 0.5 s later leg1 is seen 5 m away: nobody carries a leg at 10 m/s
    rep = a.update([det(0, "leg", 5.3, 0.3), det(1, "leg", 0.3, -0.3)], 0.5)
    assert len(rep.inconsistencies) == 1 and "leg1" in rep.inconsistencies[0]
    assert not kb.consistent and kb.position("leg1")[:2] == pytest.approx((0.3, 0.3))
    assert rep.new_objects == []  # not a new leg either
    # the next percept agrees with the base: the inconsistent state ends
    rep = a.update([det(0, "leg", 0.3, 0.3), det(1, "leg", 0.3, -0.3)], 1.0)
    assert rep.cleared == ["leg1"] and kb.consistent


def test_a_move_an_agent_could_make_re_anchors_and_is_reported():
    kb = base()
    a = Anchoring(kb, ["leg"])
    a.update([det(0, "leg", 0.3, 0.3), det(1, "leg", 0.3, -0.3)], 0.0)
    rep = a.update([det(0, "leg", 0.3, 0.52), det(1, "leg", 0.3, -0.3)], 2.0)
    assert rep.moved == ["leg1"] and kb.consistent
    assert kb.position("leg1")[:2] == pytest.approx((0.3, 0.52))


def test_a_belief_an_action_predicted_that_the_percept_denies_is_an_inconsistency():
    kb = base()
    a = Anchoring(kb, ["leg"])
    a.update([det(0, "leg", 0.3, 0.3), det(1, "leg", 0.3, -0.3)], 0.0)
    kb.move("leg1", (1.1, 0.0, 0.1))  # e.g. a report: the operator picked it up
    a.expect("leg1")
    rep = a.update([det(0, "leg", 0.3, 0.3), det(1, "leg", 0.3, -0.3)], 1.0)
    assert rep.inconsistencies and "should be at (1.100" in rep.inconsistencies[0]
    # the operator really takes it: seen where the base says -> consistent again
    rep = a.update([det(0, "leg", 1.1, 0.0), det(1, "leg", 0.3, -0.3)], 2.0)
    assert rep.cleared == ["leg1"] and kb.consistent


def test_a_fixed_object_seen_elsewhere_is_an_inconsistency():
    kb = base()
    a = Anchoring(kb, ["leg"])
    a.update([det(0, "leg", 0.3, 0.3), det(1, "leg", 0.3, -0.3)], 0.0)
    kb.set_fixed("leg1")
    rep = a.update([det(0, "leg", 0.36, 0.3), det(1, "leg", 0.3, -0.3)], 1.0)
    assert rep.inconsistencies and "fixed" in rep.inconsistencies[0]


def test_a_partly_hidden_part_confirms_its_symbol_without_moving_it():
    kb = base()
    a = Anchoring(kb, ["leg"])
    a.update([det(0, "leg", 0.3, 0.3), det(1, "leg", 0.3, -0.3)], 0.0)
    rep = a.update([det(0, "leg", 0.38, 0.3, length=0.24), det(1, "leg", 0.3, -0.3)], 1.0)
    assert rep.anchored["leg1"] == "c0" and rep.moved == []
    assert kb.position("leg1")[:2] == pytest.approx((0.3, 0.3))


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"gate_m": 0}, "gate_m"),
        ({"gate_m": float("nan")}, "gate_m"),
        ({"max_speed_m_s": -1}, "max_speed"),
        ({"missing_after": 0}, "missing_after"),
    ],
)
def test_bad_parameters_are_refused(kw, match):
    with pytest.raises(ValueError, match=match):
        Anchoring(base(), ["leg"], **kw)


def test_a_frame_needs_a_finite_time():
    with pytest.raises(ValueError, match="finite"):
        Anchoring(base(), ["leg"]).update([], float("inf"))


def test_knowledge_base_observe_and_contradict():
    kb = base()
    assert kb.compatible("leg", "leg") and not kb.compatible("leg", "tabletop")
    assert not kb.observe("leg1", (0.3, 0.3, 0.0), "tabletop")  # incompatible type
    assert not kb.consistent
    assert kb.observe("leg1", (0.31, 0.3, 0.0), "leg") and kb.consistent  # clears it
    kb.contradict("leg2", "seen where it cannot be", {"position": (9, 9, 9)})
    assert [i.reason for i in kb.inconsistencies] == ["seen where it cannot be"]
    assert kb.to_dict()["objects"][0]["anchored"] is True


def test_a_predicted_belief_nobody_asked_to_check_follows_the_percept():
    kb = base()
    a = Anchoring(kb, ["leg"])
    a.update([det(0, "leg", 0.3, 0.3), det(1, "leg", 0.3, -0.3)], 0.0)
    kb.move("leg1", (0.6, 0.0, 0.0))  # e.g. a stopped arm's guess of where it let go
    rep = a.update([det(0, "leg", 0.3, 0.3), det(1, "leg", 0.3, -0.3)], 1.0)
    assert rep.inconsistencies == [] and rep.moved == ["leg1"]
    assert kb.position("leg1")[:2] == pytest.approx((0.3, 0.3))
