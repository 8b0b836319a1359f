"""Acceptance: two arms overlap, one arm never does; falling activation; determinism; transport."""

import json
import math
from itertools import pairwise

import pytest

from flexhrc.behavior import (
    BehaviorNetwork,
    NetworkParams,
    check_run,
    parse_prefix,
    random_world,
    run_task,
)
from flexhrc.behavior.messages import from_wire, to_wire
from flexhrc.scenario.builtin.table_setting import LAYOUTS, load_scenario
from flexhrc.transport import InProcessBus


def overlaps(runs):
    return [
        (a, b)
        for i, a in enumerate(runs)
        for b in runs[i + 1 :]
        if a.start < b.end and b.start < a.end
    ]


@pytest.mark.parametrize("layout", LAYOUTS)
def test_two_arms_overlap_independent_behaviours_one_arm_never_does(layout):
    one = load_scenario("table-setting", layout, arms=1)
    two = load_scenario("table-setting", layout, arms=2)
    r1 = run_task(one.task, one.world)
    r2 = run_task(two.task, two.world)
    assert r1.outcome == r2.outcome == "done"
    assert check_run(one.task, r1.runs) == [] and check_run(two.task, r2.runs) == []
    assert overlaps(r1.runs) == []
    pairs = overlaps(r2.runs)
    assert pairs, "with two mutexes some behaviours must run in parallel"
    assert all(a.arm != b.arm for a, b in pairs)  # never two on one arm
    assert {r.arm for r in r2.runs} == {"left", "right"}
    assert r2.time < r1.time


def test_falling_activation_node_cut_off_from_its_parent_decays_and_stops():
    task = parse_prefix("(THEN a (AND (THEN b c) (OR d e (THEN f g))))")
    params = NetworkParams(falloff=0.8, tau_active=0.1)
    net = BehaviorNetwork(task, random_world(task.behaviors, seed=2), params)
    and1 = net.node("AND_1")
    while and1.state != "active":
        net.tick()
    and1.disconnect_parent()  # the link THEN_1 -> AND_1 is broken
    cut_tick = net.clock.tick
    levels = [and1.level]
    for _ in range(60):
        net.tick()
        levels.append(and1.level)
    # geometric fall-off by exactly α per update loop, until below τ_active ...
    k = next(i for i, lv in enumerate(levels) if lv <= params.tau_active)
    for prev, cur in pairwise(levels[: k + 1]):
        assert cur == pytest.approx(prev * params.falloff)
    assert k == math.ceil(math.log(params.tau_active / levels[0]) / math.log(params.falloff))
    assert and1.state == "inactive"
    # ... and then the whole sub-tree goes quiet: nothing new starts, nothing stays active
    result = net.run(max_ticks=cut_tick + 3000)
    assert result.outcome == "timeout"
    late = [e for e in result.log if e.kind == "start" and e.tick > cut_tick + 10 * k]
    assert late == []
    for name in ("b", "c", "d", "e", "f", "g", "THEN_2", "OR_1", "THEN_3"):
        assert net.node(name).state in ("inactive", "done"), name


def test_root_without_driver_decays_and_nothing_runs():
    task = parse_prefix("(AND a b)")
    net = BehaviorNetwork(task, random_world(task.behaviors, seed=0), NetworkParams(falloff=0.5))
    net.tick()
    net.tick()
    net.drive = False
    result = net.run(max_ticks=500)
    assert result.outcome == "timeout"
    assert [e for e in result.log if e.kind == "start"] == []
    assert all(n.state == "inactive" for n in net.nodes.values())


def test_same_seed_same_log_and_json_serialisable():
    def log_of(seed):
        sc = load_scenario("table-setting-robustness", arms=2)
        res = BehaviorNetwork(sc.task, sc.world, NetworkParams(seed=seed)).run()
        return [e.to_dict() for e in res.log]

    a, b = log_of(7), log_of(7)
    assert a == b
    assert json.loads(json.dumps(a)) == a


class SerialisingBus(InProcessBus):
    """A bus that sends every payload through JSON, as a network transport would."""

    def publish(self, topic, payload):
        super().publish(topic, from_wire(json.loads(json.dumps(to_wire(payload)))))


def test_network_runs_unchanged_over_a_serialising_transport():
    sc = load_scenario("table-setting", 2)
    plain = run_task(sc.task, sc.world)
    sc2 = load_scenario("table-setting", 2)
    wired = BehaviorNetwork(sc2.task, sc2.world, transport=SerialisingBus()).run()
    assert wired.order == plain.order
    assert [r.to_dict() for r in wired.runs] == [r.to_dict() for r in plain.runs]


@pytest.mark.parametrize("scenario", ["table-setting", "table-setting-robustness"])
def test_event_driven_stepping_gives_exactly_the_log_of_updating_every_node(scenario):
    logs = []
    for event_driven in (True, False):
        sc = load_scenario(scenario, arms=2)
        net = BehaviorNetwork(sc.task, sc.world, event_driven=event_driven)
        logs.append([e.to_dict() for e in net.run().log])
    assert logs[0] == logs[1]
