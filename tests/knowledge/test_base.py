import math

import pytest

from flexhrc.errors import FlexhrcError, UnknownNameError
from flexhrc.knowledge import KnowledgeBase
from flexhrc.logic import parse_conjunction, satisfy


def kb() -> KnowledgeBase:
    k = KnowledgeBase()
    k.add_object("leg1", "leg", (0.4, 0.3, 0.0), {"length": 0.4})
    k.add_object("leg2", "leg", (0.5, -0.3, 0.0), {"length": 0.4})
    k.add_object("top", "tabletop", (0.5, 0.0, 0.0), {"width": 0.5})
    k.assert_fact("on_table", "leg1")
    k.assert_fact("on_table", "leg2")
    return k


def test_types_are_facts_and_queries_are_closed_world():
    k = kb()
    assert k.query(parse_conjunction("leg(?l) & on_table(?l)")) == [{"?l": "leg1"}, {"?l": "leg2"}]
    k.retract_fact("on_table", "leg1")
    assert k.query(parse_conjunction("leg(?l) & not on_table(?l)")) == [{"?l": "leg1"}]
    assert not k.holds("connected", "leg1", "top")


def test_effects_delete_then_add():
    k = kb()
    k.apply_effects(
        parse_conjunction("held(?l)"), parse_conjunction("on_table(?l)"), {"?l": "leg2"}
    )
    assert k.holds("held", "leg2") and not k.holds("on_table", "leg2")
    with pytest.raises(FlexhrcError, match="not ground"):
        k.apply_effects(parse_conjunction("held(?x)"), (), {})


def test_percept_agreeing_updates_pose():
    k = kb()
    assert k.update_object("leg1", "leg", (0.41, 0.3, 0.0), {"length": 0.401})
    assert k.position("leg1") == (0.41, 0.3, 0.0) and k.consistent
    assert k.update_object("leg9", "leg", (0.1, 0.1, 0.0))  # new objects are simply added
    assert "leg9" in k.objects


@pytest.mark.parametrize(
    ("percept", "words"),
    [
        ({"type": "tabletop", "pose": (0.4, 0.3, 0.0)}, "perceived as a tabletop"),
        ({"type": "leg", "pose": (0.4, 0.3, 0.0), "size": {"length": 0.3}}, "length 0.4 known"),
    ],
)
def test_contradicting_percept_makes_the_base_inconsistent(percept, words):
    k = kb()
    before = k.objects["leg1"].to_dict()
    assert not k.update_object("leg1", **percept)
    assert not k.consistent and words in k.inconsistencies[0].reason
    assert k.objects["leg1"].to_dict() == before  # nothing silently overwritten
    k.resolve("leg1", accept=False)
    assert k.consistent and k.objects["leg1"].to_dict() == before


def test_fixed_object_seen_elsewhere_and_accepting_the_percept():
    k = kb()
    k.set_fixed("leg1")
    assert not k.update_object("leg1", "leg", (0.9, 0.0, 0.0))
    assert "is fixed" in k.inconsistencies[0].reason
    k.resolve(accept=True)
    assert k.consistent and k.position("leg1") == (0.9, 0.0, 0.0) and not k.objects["leg1"].fixed


def test_errors_name_the_problem():
    k = kb()
    with pytest.raises(UnknownNameError, match="no object 'nope'"):
        k.position("nope")
    with pytest.raises(FlexhrcError, match="already exists"):
        k.add_object("leg1", "leg", (0, 0, 0))
    with pytest.raises(FlexhrcError, match="three finite numbers"):
        k.add_object("x", "leg", (0, 0))


def test_scene_perception_feeds_the_knowledge_base():
    """Recognised objects go to the knowledge base through the ObjectSink protocol."""
    np = pytest.importorskip("numpy")
    pytest.importorskip("scipy")
    from flexhrc.perception.scene.cloud import depth_to_cloud
    from flexhrc.perception.scene.pipeline import ScenePerception
    from flexhrc.perception.scene.synthetic import generate_scene, render_depth
    from flexhrc.perception.scene.types import publish_objects

    rng = np.random.default_rng(0)
    scene = generate_scene(rng, n_legs=3, n_clutter=(0, 0))
    depth = render_depth(scene, noise=0.002, rng=rng)
    objects = ScenePerception().process(depth_to_cloud(depth, scene.intrinsics, scene.extrinsics))
    k = KnowledgeBase()
    assert publish_objects(k, objects) == len(objects)
    # the rule set types legs by length (leg_long / leg_short); a task written for legs sees both
    assert k.supertypes == {}
    legs = [o for o in k.objects.values() if o.type.startswith("leg_")]
    assert len(legs) == 3 and all(0.2 < o.size["length"] < 0.5 for o in legs)
    assert len(k.query(parse_conjunction("leg_short(?l)"))) == 2 and k.consistent
    typed = KnowledgeBase(supertypes={"leg_long": "leg", "leg_short": "leg"})
    publish_objects(typed, objects)
    assert len(typed.query(parse_conjunction("leg(?l)"))) == 3
    assert len(typed.objects_of_type("leg")) == 3
    # the same object seen again as something else is not silently accepted
    first = objects[0]
    assert not k.update_object(first.id, "sphere_thing", first.pose, tuple(first.size))
    assert not k.consistent


def test_supertypes_and_their_errors():
    k = KnowledgeBase(supertypes={"leg_long": "leg", "leg": "part"})
    k.add_object("l1", "leg_long", (0, 0, 0))
    assert k.holds("leg_long", "l1") and k.holds("leg", "l1") and k.holds("part", "l1")
    assert [o.id for o in k.objects_of_type("part")] == ["l1"]
    assert not k.update_object("l1", "leg_short", (0, 0, 0))  # a different type: inconsistent
    k.resolve("l1", accept=True)
    assert k.holds("leg_short", "l1") and not k.holds("leg", "l1")
    bad = KnowledgeBase(supertypes={"a": "b", "b": "a"})
    with pytest.raises(FlexhrcError, match="cycle"):
        bad.add_object("x", "a", (0, 0, 0))


def test_kept_views_of_the_facts_follow_every_change():
    """``facts`` and the index behind ``query`` are kept between changes: every way the facts
    change makes new ones, and a snapshot taken before a change stays what it was."""
    k = kb()
    on_table = parse_conjunction("on_table(?l)")
    before = k.facts
    assert k.facts is before  # kept while nothing changes
    changes = [
        lambda: k.retract_fact("on_table", "leg1"),
        lambda: k.assert_fact("on_table", "leg1"),
        lambda: k.apply_effects((), parse_conjunction("on_table(?l)"), {"?l": "leg2"}),
        lambda: k.add_object("leg3", "leg", (0.1, 0.1, 0.0)),
        lambda: k.assert_fact("on_table", "leg3"),
    ]
    for change in changes:
        seen = k.facts
        k.query(on_table)  # the index is made
        change()
        assert k.facts == frozenset(k._facts) and k.facts is not seen
        assert k.query(on_table) == [s for s in satisfy(on_table, set(k._facts))]
        assert seen != k.facts
    assert ("on_table", "leg1") in before and ("leg", "leg3") not in before
    # an effect refused half-way (not ground) leaves the views of what was applied
    assert k.facts == frozenset(k._facts)  # a view is kept
    with pytest.raises(FlexhrcError, match="not ground"):
        k.apply_effects(
            parse_conjunction("held(?x)"), parse_conjunction("on_table(?l)"), {"?l": "leg1"}
        )
    assert ("on_table", "leg1") not in k.facts and k.facts == frozenset(k._facts)
    # an accepted percept changes the object's type facts
    k.update_object("leg3", "tabletop", (0.1, 0.1, 0.0))
    types = k.facts
    k.resolve("leg3", accept=True)
    assert ("tabletop", "leg3") in k.facts and ("tabletop", "leg3") not in types


@pytest.mark.parametrize(
    "p", [(float("nan"), 0.0, 0.0), [0.0, float("inf"), 0.0], (0.0, 0.0, -float("inf")), [1.0]]
)
def test_a_position_of_three_floats_is_checked_on_the_quick_path_too(p):
    k = kb()
    with pytest.raises(FlexhrcError, match="three finite numbers"):
        k.move("leg1", p)
    k.move("leg1", [0.1, 0.2, 0.3])
    k.move("leg2", (1, 2, 3))  # ints are numbers too
    assert k.position("leg1") == (0.1, 0.2, 0.3) and k.position("leg2") == (1.0, 2.0, 3.0)
    assert all(type(v) is float for v in k.position("leg2"))


# -- issue 21, item 10: every way a percept arrives clears an inconsistency; continuity -------
def test_a_compatible_percept_through_update_object_ends_the_inconsistent_state():
    """``update_object`` (the perception modules' sink, the live cell's percepts) clears the
    object's pending inconsistency when compatible information arrives, as ``observe`` does
    (paper 000, VI-E: the base "waits for new, compatible, information")."""
    k = kb()
    assert not k.update_object("leg1", "leg", (0.4, 0.3, 0.0), {"length": 0.3})  # size off
    k.contradict("leg1", "a caller's own check", {"position": (0.9, 0.9, 0.0)})
    k.contradict("leg2", "another object's", {"position": (0.9, 0.9, 0.0)})
    assert len(k.inconsistencies) == 3
    assert k.update_object("leg1", "leg", (0.41, 0.3, 0.0), {"length": 0.4})  # compatible
    assert [i.object_id for i in k.inconsistencies] == ["leg2"]  # only leg1's are over
    assert k.position("leg1") == (0.41, 0.3, 0.0)
    # an incompatible percept clears nothing
    assert not k.update_object("leg2", "tabletop", (0.5, -0.3, 0.0))
    assert [i.object_id for i in k.inconsistencies] == ["leg2", "leg2"]
    assert k.observe("leg2", (0.5, -0.3, 0.0), "leg") and k.consistent


@pytest.mark.parametrize("way", ["update_object", "observe"])
def test_continuity_a_loose_object_cannot_jump_farther_than_its_speed_allows(way):
    """A non-fixed leg seen 5 m away 0.5 s after its last percept: no agent moves it that fast,
    the base is inconsistent (nothing overwritten) until a compatible percept comes; the same
    distance after long enough is a motion. Times are the percepts' own."""
    k = kb()

    def see(pos, t):
        if way == "observe":
            return k.observe("leg1", pos, "leg", t=t)
        return k.update_object("leg1", "leg", pos, t=t)

    assert see((0.4, 0.3, 0.0), 10.0)
    assert not see((5.4, 0.3, 0.0), 10.5)
    (inc,) = k.inconsistencies
    assert inc.object_id == "leg1" and inc.percept["t"] == 10.5
    assert "leg1 perceived 5.00 m from where it was perceived 0.50 s before" in inc.reason
    assert "faster than 1.5 m/s" in inc.reason
    assert k.position("leg1") == (0.4, 0.3, 0.0)  # the jump is not applied
    assert see((0.45, 0.3, 0.0), 10.6) and k.consistent  # compatible: the wait is over
    assert see((5.4, 0.3, 0.0), 15.0)  # 4.95 m in 4.4 s: a motion, not a jump
    assert k.position("leg1") == (5.4, 0.3, 0.0)
    assert see((5.45, 0.3, 0.0), 15.0)  # within the margin at the same time: noise
    assert k.last_percept["leg1"] == ((5.45, 0.3, 0.0), 15.0)


def test_continuity_is_configurable_explained_by_actions_and_not_for_fixed_objects():
    k = KnowledgeBase(max_speed_m_s=0.1, continuity_margin_m=0.05)
    k.add_object("leg1", "leg", (0.4, 0.3, 0.0))
    assert k.update_object("leg1", "leg", (0.4, 0.3, 0.0), t=0.0)
    assert not k.update_object("leg1", "leg", (0.7, 0.3, 0.0), t=1.0)  # 0.3 m > 0.1*1 + 0.05
    assert "faster than 0.1 m/s" in k.inconsistencies[0].reason
    k.resolve(accept=False)
    # an action's effect (the person carried it to the bolt) explains a change of any size
    k.move("leg1", (0.9, 0.0, 0.1))
    assert k.update_object("leg1", "leg", (0.91, 0.0, 0.1), t=1.0) and k.consistent
    # a percept without a time is not checked for continuity (everything else is)
    assert k.update_object("leg1", "leg", (0.2, 0.2, 0.0))
    # a fixed object is checked against where it is fixed, not its speed
    k.set_fixed("leg1")
    assert not k.update_object("leg1", "leg", (0.3, 0.2, 0.0), t=1.0)
    assert "is fixed at" in k.inconsistencies[0].reason
    # accepting the percept makes it continuity's reference
    k.resolve(accept=True)
    assert k.last_percept["leg1"] == ((0.3, 0.2, 0.0), 1.0)
    assert not k.update_object("leg1", "leg", (0.9, 0.2, 0.0), t=2.0)
    # the default bound, documented; math.inf turns the check off
    from flexhrc.knowledge.base import CONTINUITY_MARGIN_M, MAX_SPEED_M_S

    assert (
        (KnowledgeBase().max_speed_m_s, KnowledgeBase().continuity_margin_m)
        == (
            MAX_SPEED_M_S,
            CONTINUITY_MARGIN_M,
        )
        == (1.5, 0.10)
    )
    free = KnowledgeBase(max_speed_m_s=math.inf)
    free.add_object("leg1", "leg", (0.0, 0.0, 0.0))
    assert free.update_object("leg1", "leg", (0, 0, 0), t=0) and free.update_object(
        "leg1", "leg", (9, 9, 0), t=0
    )


@pytest.mark.parametrize(
    ("kw", "words"),
    [
        ({"max_speed_m_s": 0}, "max_speed_m_s must be a number > 0, got 0"),
        ({"max_speed_m_s": float("nan")}, "max_speed_m_s must be a number > 0"),
        ({"continuity_margin_m": -1}, "continuity_margin_m must be a number > 0, got -1"),
        ({"max_speed_m_s": "fast"}, "max_speed_m_s must be a number > 0, got 'fast'"),
    ],
)
def test_continuity_bounds_are_checked(kw, words):
    with pytest.raises(FlexhrcError, match=words):
        KnowledgeBase(**kw)


def test_a_percept_time_must_be_finite():
    k = kb()
    with pytest.raises(FlexhrcError, match="time of a percept must be a finite number"):
        k.update_object("leg1", "leg", (0.4, 0.3, 0.0), t=float("nan"))
