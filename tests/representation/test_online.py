import pytest

from flexhrc.errors import FlexhrcError, UnknownNameError
from flexhrc.representation import InfeasibleUpdateError, OnlineGraph
from flexhrc.representation.paths import exact_costs

from .helpers import diamond, two_layer


def test_leaves_start_feasible_and_costs_are_cheapest_paths():
    g = OnlineGraph(diamond())
    # path via h1: a1 + b0 + h1 3 + root 1 = 5 ; via h2: b0 + c2 + h2 1 + root 1 = 4
    assert g.query().feasible == {"a": 5, "b": 4, "c": 4}
    assert g.optimal_cost() == 4
    assert [s.element for s in g.suggestions()] == ["b", "c", "a"]  # ties: definition order


def test_hyperarc_feasible_when_all_children_met_eq7():
    g = OnlineGraph(diamond())
    r = g.update(met_nodes=["b"])
    assert "h1" not in r.feasible and "h2" not in r.feasible
    r = g.update(met_nodes=["c"])
    assert r.feasible["h2"] == 2  # h2 1 + root 1
    assert g.is_feasible("h2") and not g.is_feasible("h1")


def test_solving_blocks_alternatives_sharing_a_child_algorithm2():
    g = OnlineGraph(diamond())
    g.update(met_nodes=["a", "b", "c"])
    r = g.update(solved_hyperarcs=["h2"])
    assert g.is_blocked("h1") and not g.is_feasible("h1")
    assert r.feasible == {"root": 1}  # eq. 6: parent of a solved hyper-arc becomes feasible
    r = g.update(met_nodes=["root"])
    assert r.solved and g.solved and r.outcome == "solved"


def test_one_query_can_report_a_chain():
    g = OnlineGraph(diamond())
    r = g.update(met_nodes=["root", "b", "c"], solved_hyperarcs=["h2"])
    assert r.solved


def test_infeasible_update_changes_nothing():
    g = OnlineGraph(diamond())
    before = g.state()
    with pytest.raises(InfeasibleUpdateError, match="h1"):
        g.update(met_nodes=["a"], solved_hyperarcs=["h1"])  # b is not met
    assert g.state() == before
    assert g.events == []
    with pytest.raises(UnknownNameError, match="did you mean"):
        g.update(met_nodes=["root2"])
    with pytest.raises(UnknownNameError, match="hyper-arc"):
        g.update(met_nodes=["h1"])
    assert g.state() == before


def test_already_met_is_ignored_not_an_error():
    g = OnlineGraph(diamond())
    g.update(met_nodes=["a"])
    r = g.update(met_nodes=["a", "b"])
    assert r.ignored == ["a"] and g.is_met("b")


def test_mark_infeasible_reroutes_and_then_fails():
    g = OnlineGraph(diamond())
    r = g.mark_infeasible("h2")
    assert r.feasible == {"a": 5, "b": 5}  # c only leads through h2
    r = g.mark_infeasible("h1")
    assert r.failed and r.outcome == "failed" and "root" in r.reason
    with pytest.raises(FlexhrcError, match="already failed"):
        g.update(met_nodes=["a"])


def test_failed_when_nothing_feasible_is_explicit():
    g = OnlineGraph(diamond())
    g.update(met_nodes=["a", "b", "c"])
    r = g.mark_infeasible("h1", "h2")
    assert r.failed and r.reason == "no feasible node or hyper-arc is left"


def test_lower_graph_activates_when_upper_children_met_eq17():
    g = OnlineGraph(two_layer())
    r = g.query()
    assert set(r.feasible) == {"x", "y"}
    # eq. 19: w(H) is the lower graph's optimal path cost (2), not the declared 100
    assert r.feasible["x"] == 2 and g.optimal_cost() == 2
    r = g.update(met_nodes=["x", "y"])
    assert set(r.feasible) == {"H/p", "H/q"}
    assert {s.graph for s in r.suggestions} == {"H"}
    assert r.suggestions[0].graph_name == "low"
    r = g.update(met_nodes=["H/q"])
    assert r.feasible == {"H/l2": 5, "H/p": 2}
    r = g.update(met_nodes=["H/p"], solved_hyperarcs=["H/l1"])
    r = g.update(met_nodes=["H/r"])
    # eq. 18: lower root met -> upper hyper-arc solved -> its parent feasible
    assert g.is_solved("H") and r.feasible == {"t0": 0}
    assert g.update(met_nodes=["t0"]).solved


def test_lower_graph_failure_makes_upper_arc_infeasible():
    g = OnlineGraph(two_layer())
    g.update(met_nodes=["x", "y"])
    r = g.mark_infeasible("H/r")
    assert r.failed
    assert g.is_blocked("H")


def test_dp_matches_exact_enumeration_on_small_graphs():
    g = OnlineGraph(two_layer())
    assert g.query().feasible == exact_costs(g)
    g.update(met_nodes=["x", "y", "H/q"])
    assert g.query().feasible == exact_costs(g)


def test_events_save_load_replay(tmp_path):
    g = OnlineGraph(two_layer())
    g.update(met_nodes=["x"])
    g.update(met_nodes=["y", "H/q"])
    g.mark_infeasible("H/l2")
    path = tmp_path / "events.jsonl"
    g.save_events(path)
    events = OnlineGraph.load_events(path)
    assert [e.type for e in events] == ["met", "met", "met", "infeasible"]
    again = OnlineGraph.replay(two_layer(), events)
    assert again.state() == g.state()


def test_load_events_reports_line(tmp_path):
    p = tmp_path / "bad.jsonl"
    p.write_text('{"query": 1, "type": "met", "element": "x"}\n{"query": 2}\n')
    with pytest.raises(FlexhrcError, match=r"bad.jsonl:2"):
        OnlineGraph.load_events(p)


def test_exact_enumeration_is_guarded_by_a_limit():
    from flexhrc.representation.paths import PathLimitError, count_paths

    g = OnlineGraph(diamond())
    assert count_paths(g) == {"": 2}
    with pytest.raises(PathLimitError, match="more than 1 cooperation paths"):
        count_paths(g, limit=1)
