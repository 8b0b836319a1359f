"""The latched protocol (held activation, standing mutex bids): what goes on the wire, and that it
changes nothing the nodes see — runs are identical to the paper's per-tick messages."""

from __future__ import annotations

import pytest

from flexhrc.behavior import (
    AndNode,
    ArmMutex,
    BehaviorNetwork,
    MutexRequest,
    NetworkParams,
    ThenNode,
    parse_prefix,
    random_world,
)
from flexhrc.behavior.messages import (
    ActivationMsg,
    ActivationRelease,
    MutexWithdraw,
    reply_topic,
    request_topic,
)
from flexhrc.scenario.builtin.table_setting import load_scenario
from flexhrc.transport import InProcessBus
from tests.behavior.test_goals import Harness


def test_and_sends_a_held_level_once_and_zero_when_it_deactivates():
    h = Harness(AndNode, ["a", "b", "c"], latched=True)
    assert h.tick() == [("a", 1 / 3), ("b", 1 / 3), ("c", 1 / 3)]
    assert h.tick() == []  # the children hold the level: nothing to re-send
    h.child_state("b", "done")
    assert h.tick() == []
    assert h.tick(level=0.0) == [("a", 0.0), ("c", 0.0)]  # cut off: zero to the not-done ones
    assert h.tick() == [("a", 1 / 3), ("c", 1 / 3)]  # active again: held again


def test_then_holds_its_current_child_only():
    h = Harness(ThenNode, ["a", "b"], latched=True)
    assert h.tick() == [("a", 1.0)]
    assert h.tick() == []
    h.child_state("a", "done")
    assert h.tick() == [("b", 1.0)]
    assert h.tick() == []


def test_a_held_level_is_reapplied_every_loop_and_a_release_lets_it_decay():
    bus = InProcessBus()
    params = NetworkParams(falloff=0.5)
    node = ThenNode("G", ["x"], bus, params)
    bus.publish("bn/G/activation", ActivationMsg("P", 0.8, hold=True))
    bus.flush()
    for tick in range(3):
        node.update(tick, tick * 0.1)
        bus.flush()
        assert node.level == pytest.approx(0.4)  # 0.8 re-applied, then one fall-off
    bus.publish("bn/G/activation", ActivationRelease("P"))
    bus.flush()
    node.update(3, 0.3)
    assert node.level == pytest.approx(0.2)  # decays from where it was


def test_standing_bids_count_every_tick_until_withdrawn():
    bus = InProcessBus()
    mutex = ArmMutex("left", bus, NetworkParams(mutex_window=0.2, tick_period=0.1))
    replies = []
    for n in "ab":
        bus.subscribe(reply_topic(n), lambda m, n=n: replies.append((n, m.granted)))
    bus.publish(request_topic("left"), MutexRequest("a", 1.0, standing=True))
    bus.publish(request_topic("left"), MutexRequest("b", 2.0, standing=True))
    bus.flush()
    mutex.update(0, 0.0)  # opens the window
    bus.publish(request_topic("left"), MutexWithdraw("b"))
    bus.flush()
    mutex.update(1, 0.1)
    bus.flush()
    mutex.update(2, 0.2)  # closes: only a's standing bid is left
    bus.flush()
    assert replies == [("a", True)] and mutex.holder == "a"


@pytest.mark.parametrize(
    ("scenario", "arms"),
    [("table-setting", 1), ("table-setting", 2), ("table-setting-robustness", 2)],
)
def test_latched_runs_equal_per_tick_runs(scenario, arms):
    logs = []
    for latched in (True, False):
        sc = load_scenario(scenario, arms=arms)
        net = BehaviorNetwork(sc.task, sc.world, NetworkParams(latched=latched))
        logs.append([e.to_dict() for e in net.run().log])
    assert logs[0] == logs[1]


def test_waiting_behaviours_sleep_and_fewer_messages_are_sent():
    task = parse_prefix("(AND " + " ".join(f"o{i}" for i in range(200)) + ")")
    counts = {}
    for latched in (True, False):
        bus = InProcessBus()
        net = BehaviorNetwork(
            task, random_world(task.behaviors, seed=0), NetworkParams(latched=latched), bus
        )
        for _ in range(300):
            net.tick()
        counts[latched] = (bus.published, len(net._awake))
    assert counts[True][1] < 10 < counts[False][1]  # 199 behaviours wait, asleep
    assert counts[True][0] * 20 < counts[False][0]


@pytest.mark.slow
def test_A11_an_and_of_1000_and_a_long_then_run_to_the_end():
    """Bad-input probe A11 (timing is in benchmarks/behavior_scale.py): an AND of 1000 leaves
    completes, and a THEN needing more than the old fixed 50 000 ticks is not cut short."""
    from flexhrc.behavior import check_run
    from flexhrc.behavior.network import default_max_ticks

    wide = parse_prefix("(AND " + " ".join(f"o{i}" for i in range(1000)) + ")")
    result = BehaviorNetwork(wide, random_world(wide.behaviors, seed=0)).run()
    assert result.outcome == "done" and len(result.order) == 1000
    long = parse_prefix("(THEN " + " ".join(f"o{i}" for i in range(600)) + ")")
    result = BehaviorNetwork(long, random_world(long.behaviors, seed=0)).run()
    assert result.ticks > 50_000 and result.outcome == "done"
    assert result.ticks < default_max_ticks(long) and check_run(long, result.runs) == []
