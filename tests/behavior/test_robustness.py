"""Acceptance: objects moved while being grasped (Fig. 6): validity checking resets the
behaviour, another one runs, the task completes."""

from flexhrc.behavior import BehaviorNetwork, check_run, run_task
from flexhrc.scenario.builtin.table_setting import load_scenario


def test_moved_object_resets_its_behaviour_and_is_completed_later():
    sc = load_scenario("table-setting-robustness")
    result = run_task(sc.task, sc.world)
    assert result.outcome == "done"
    assert check_run(sc.task, result.runs) == []
    assert result.resets == 2
    runs = result.runs
    fork_runs = [r for r in runs if r.behavior == "fork"]
    assert [r.outcome for r in fork_runs] == ["reset", "done"]
    first_reset = fork_runs[0]
    after = [r for r in runs if r.start > first_reset.start]
    assert after[0].behavior != "fork"  # another allowed behaviour runs next ...
    assert after[0].behavior == "knife"
    assert after[0].start >= first_reset.end  # ... once the mutex was released
    assert fork_runs[1].start > after[0].start  # the moved one completes later
    knife_runs = [r for r in runs if r.behavior == "knife"]
    assert [r.outcome for r in knife_runs] == ["reset", "done"]
    assert knife_runs[1].start > fork_runs[1].end  # as in Fig. 6: fork first, then the knife
    # every reset was caused by a move of that very object just before
    moves = {ev.data["object"]: ev.t for ev in result.log if ev.kind == "move"}
    for ev in (e for e in result.log if e.kind == "reset"):
        assert ev.source in moves and moves[ev.source] <= ev.t
        assert ev.data["moved"] > 0.05


def test_reset_releases_the_mutex_and_the_node_competes_again():
    sc = load_scenario("table-setting-robustness")
    net = BehaviorNetwork(sc.task, sc.world)
    result = net.run()
    log = result.log
    reset = next(e for e in log if e.kind == "reset")
    release = next(e for e in log if e.kind == "release" and e.t >= reset.t)
    assert release.data["by"] == reset.source
    grant = next(e for e in log if e.kind == "grant" and e.t > release.t)
    assert reset.source in grant.data["bids"]  # the reset behaviour bid again at once
    state_after_reset = next(
        e for e in log if e.kind == "state" and e.source == reset.source and e.t == reset.t
    )
    assert state_after_reset.data["frm"] == "running" and state_after_reset.data["to"] == "active"
    assert net.node("fork").snapshot()["resets"] == 1


def test_without_moves_nothing_is_reset():
    sc = load_scenario("table-setting-robustness")
    sc.world.moves.clear()
    sc.world._fired.clear()
    result = run_task(sc.task, sc.world)
    assert result.resets == 0 and result.outcome == "done"
