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
