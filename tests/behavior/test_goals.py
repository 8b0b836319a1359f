"""Goal nodes in isolation: feed them state messages on a bus, watch what they send."""

import pytest

from flexhrc.behavior import ActivationMsg, AndNode, NetworkParams, OrNode, StateMsg, ThenNode
from flexhrc.behavior.messages import activation_topic, state_topic
from flexhrc.transport import InProcessBus


class Harness:
    """The literal per-tick protocol of the paper (``latched=False``) unless told otherwise;
    the latched protocol is tested against it below and in test_latched.py."""

    def __init__(self, cls, children, **params):
        self.bus = InProcessBus()
        params.setdefault("latched", False)
        self.params = NetworkParams(**params)
        self.node = cls("G", children, self.bus, self.params)
        self.children = children
        self.received: list[tuple[str, float]] = []
        for c in children:
            self.bus.subscribe(
                activation_topic(c), lambda m, c=c: self.received.append((c, m.level))
            )
        self.tick_no = 0

    def child_state(self, child, state="inactive", potential=0.0, progress=False, engaged=None):
        if engaged is None:
            engaged = state in ("active", "running")
        self.bus.publish(
            state_topic(child), StateMsg(child, state, 0.0, potential, progress, engaged, 0)
        )

    def tick(self, level=1.0):
        """Parent gives `level`, the node runs one update loop, messages are delivered."""
        self.bus.publish(activation_topic("G"), ActivationMsg("P", level))
        self.bus.flush()
        self.received.clear()
        self.node.update(self.tick_no, self.tick_no * 0.1)
        self.tick_no += 1
        self.bus.flush()
        return list(self.received)


def test_then_activates_only_the_first_child_not_done():
    h = Harness(ThenNode, ["a", "b", "c"])
    assert h.tick() == [("a", 1.0)]
    h.child_state("a", "done")
    assert h.tick() == [("b", 1.0)]
    h.child_state("b", "done")
    h.child_state("c", "running")
    assert h.tick() == [("c", 1.0)]
    h.child_state("c", "done")
    assert h.tick() == []
    assert h.node.state == "done"


def test_and_divides_activation_among_children_and_skips_done_ones():
    h = Harness(AndNode, ["a", "b", "c", "d"])
    assert h.node.child_level == pytest.approx(0.25)
    assert h.tick() == [("a", 0.25), ("b", 0.25), ("c", 0.25), ("d", 0.25)]
    h.child_state("b", "done")
    assert [c for c, _ in h.tick()] == ["a", "c", "d"]


def test_and_spread_modes_fixed_and_auto_fallback():
    fixed = Harness(AndNode, ["a", "b"], and_spread="fixed", and_level=0.8)
    assert fixed.node.child_level == 0.8
    many = [f"x{i}" for i in range(20)]  # 1/20 = 0.05 would never exceed tau = 0.1
    assert Harness(AndNode, many).node.child_level == 1.0
    assert Harness(AndNode, many, and_spread="divide").node.child_level == pytest.approx(0.05)


def test_goal_potential_is_mean_for_then_and_and_max_for_or():
    for cls, expected in ((ThenNode, 2.0), (AndNode, 2.0), (OrNode, 4.0)):
        h = Harness(cls, ["a", "b", "c"])
        h.child_state("a", potential=1.0)
        h.child_state("b", potential=1.0)
        h.child_state("c", potential=4.0)
        h.tick(level=0.0)  # potential flows up even while inactive
        assert h.node.potential == pytest.approx(expected), cls.kind


def test_or_activates_highest_potential_child_and_zeroes_the_previous_one():
    h = Harness(OrNode, ["a", "b", "c"])
    h.child_state("a", potential=1.0)
    h.child_state("b", potential=3.0)
    h.child_state("c", potential=2.0)
    assert h.tick() == [("b", 1.0)]
    h.child_state("b", "active", potential=3.0)
    h.child_state("c", potential=5.0)
    # switching is safe: explicit zero to b, and c gets nothing until b reports it is quiet
    assert h.tick() == [("b", 0.0)]
    assert h.tick() == []
    h.child_state("b", "inactive", potential=3.0)
    assert h.tick() == []  # ... and not before the zero's round trip (two ticks)
    assert h.tick() == [("c", 1.0)]
    assert h.node.chosen == 2


def test_or_commits_to_the_alternative_that_has_started():
    h = Harness(OrNode, ["a", "b"])
    h.child_state("a", potential=2.0)
    h.child_state("b", potential=1.0)
    assert h.tick() == [("a", 1.0)]
    h.child_state("a", "active", potential=9.0)
    h.child_state("b", "running", potential=1.0, progress=True)  # b won a mutex meanwhile
    assert h.tick() == [("a", 0.0)]  # commit to b: a is silenced first ...
    h.child_state("a", "inactive", potential=9.0)
    h.tick()
    h.tick()
    assert h.tick() == [("b", 1.0)]  # ... then b is fed, whatever a's potential
    assert h.tick() == [("b", 1.0)]
    h.child_state("b", "done", potential=1.0, progress=True)
    h.tick()
    assert h.node.state == "done"


def test_or_ties_are_broken_by_seed_and_stick():
    def first_choice(seed):
        h = Harness(OrNode, ["a", "b", "c", "d"], seed=seed)
        for c in h.children:
            h.child_state(c, potential=1.0)
        picks = [h.tick()[-1][0] for _ in range(5)]
        assert len(set(picks)) == 1  # a tie decision, once taken, does not flip-flop
        return picks[0]

    choices = {seed: first_choice(seed) for seed in range(12)}
    assert choices == {seed: first_choice(seed) for seed in range(12)}  # reproducible
    assert len(set(choices.values())) > 1  # but really random across seeds


def test_inactive_goal_does_not_spread_and_level_decays():
    h = Harness(ThenNode, ["a", "b"], falloff=0.5, tau_active=0.1)
    assert h.tick(level=1.0) == [("a", 1.0)]
    assert h.node.level == pytest.approx(0.5)
    # dropping below τ: no more positive activation, and an explicit zero to the children it fed
    assert h.tick(level=0.05) == [("a", 0.0), ("b", 0.0)]
    assert h.node.state == "inactive"
    assert h.tick(level=0.05) == []
