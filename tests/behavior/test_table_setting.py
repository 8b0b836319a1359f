"""Acceptance: the paper's table-setting runs (Figs. 2–4), checked by the independent validator."""

import math

import pytest

from flexhrc.behavior import (
    BehaviorNetwork,
    TabletopWorld,
    Task,
    check_nearest_first,
    check_run,
    run_task,
)
from flexhrc.scenario.builtin.table_setting import (
    LAYOUTS,
    PAPER_ORDERS,
    load_scenario,
    table_setting_task,
)

DRINKS = ("wineglass", "cup", "soda_can")


def rest_distances(world: TabletopWorld) -> dict[str, float]:
    """Distance from the (single) arm's rest pose to every object, before the run starts."""
    (arm,) = world.arms.values()
    return {name: math.dist(arm.home, o.position) for name, o in world.objects.items()}


@pytest.mark.parametrize("layout", LAYOUTS)
def test_every_layout_respects_the_constraints_and_takes_the_nearest_allowed_object(layout):
    sc = load_scenario("table-setting", layout)
    distances = rest_distances(sc.world)
    result = run_task(sc.task, sc.world)
    assert result.outcome == "done"
    assert check_run(sc.task, result.runs) == []
    assert check_nearest_first(sc.task, result.order, distances) == []
    assert sum(1 for b in result.order if b in DRINKS) == 1  # exactly one OR alternative ran
    assert result.order[0] == "placemat"
    assert result.order.index("plate") < result.order.index("bowl")
    assert result.resets == 0


@pytest.mark.parametrize("layout", LAYOUTS)
def test_layouts_reproduce_the_orders_reported_in_the_paper(layout):
    sc = load_scenario("table-setting", layout)
    assert run_task(sc.task, sc.world).order == PAPER_ORDERS[layout]


def test_order_comes_from_the_world_not_from_a_list():
    """Swap the fork and the spoon of layout 1: the executed order follows the objects."""
    sc = load_scenario("table-setting", 1)
    fork, spoon = sc.world.object_position("fork"), sc.world.object_position("spoon")
    sc.world.move_object("fork", spoon)
    sc.world.move_object("spoon", fork)
    distances = rest_distances(sc.world)
    result = run_task(sc.task, sc.world)
    assert result.order == ["placemat", "plate", "wineglass", "bowl", "fork", "knife", "spoon"]
    assert check_nearest_first(sc.task, result.order, distances) == []


def test_drink_alternative_follows_the_nearest_drink():
    sc = load_scenario("table-setting", 1)
    sc.world.move_object("soda_can", (0.3, -0.05, 0.75))  # now the nearest object of all
    result = run_task(sc.task, sc.world)
    assert [b for b in result.order if b in DRINKS] == ["soda_can"]
    assert check_run(sc.task, result.runs) == []


def test_validator_catches_wrong_orders():
    """The validator is not a rubber stamp: it rejects runs that break each kind of constraint."""
    from flexhrc.behavior import Run

    task: Task = table_setting_task()

    def runs(order, arm="arm"):
        return [Run(b, arm, 10.0 * i, 10.0 * i + 9.0, "done") for i, b in enumerate(order)]

    good = PAPER_ORDERS[1]
    assert check_run(task, runs(good)) == []
    bad_then = ["plate", "placemat", "wineglass", "bowl", "spoon", "knife", "fork"]
    assert any("THEN_1" in p for p in check_run(task, runs(bad_then)))
    bowl_first = ["placemat", "bowl", "plate", "wineglass", "spoon", "knife", "fork"]
    assert any("THEN_2" in p for p in check_run(task, runs(bowl_first)))
    two_drinks = [*good, "cup"]
    assert any("OR_1" in p for p in check_run(task, runs(two_drinks)))
    missing = good[:-1]
    assert any("not completed" in p for p in check_run(task, runs(missing)))
    overlapping = [Run("placemat", "arm", 0, 5, "done"), Run("plate", "arm", 4, 9, "done")]
    assert any("arm arm" in p for p in check_run(task, overlapping, require_complete=False))
    near = {b: 100.0 for b in task.behaviors}
    near.update({b: float(i) for i, b in enumerate(good)})
    assert check_nearest_first(task, good, near) == []
    near["fork"] = 0.5
    assert check_nearest_first(task, good, near)  # fork was nearer than plate at step 2


def test_network_nodes_exchange_only_messages():
    """No node holds a reference to another node or to a mutex: all coupling is by topic."""
    from flexhrc.behavior import ArmMutex, Node

    sc = load_scenario("table-setting", 1, arms=2)
    net = BehaviorNetwork(sc.task, sc.world)
    peers = (Node, ArmMutex)

    def refs(value):
        if isinstance(value, dict):
            for k, v in value.items():
                yield k
                yield v
        elif isinstance(value, list | tuple | set):
            yield from value
        else:
            yield value

    for obj in [*net.nodes.values(), *net.mutexes]:
        for attr, value in vars(obj).items():
            for item in refs(value):
                assert not (isinstance(item, peers) and item is not obj), f"{obj.name}.{attr}"
