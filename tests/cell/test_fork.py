"""What-if from the store (issue 22, item 5): ``flexhrc replay STORE --fork-at K``.

A fork copies the first K events of a cell's store into a new one and resumes it through the
one loop with simulated agents: with the stored choices it reproduces the stored run to its
end, event for event; with another operator profile it goes another way, and both summaries
print side by side."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import pytest

from flexhrc.cell.fork import fork_store
from flexhrc.cell.serve import CellConfig, serve_cell
from flexhrc.cell.store import EventStore, StoredEvent, read_store, summarise_store
from flexhrc.cli import main
from flexhrc.scenario import load_scenario


def _load(name: str, seed: int) -> Any:
    return load_scenario(name, seed=seed)


def _stored(tmp_path: Path, name: str, human: str) -> Path:
    store = tmp_path / f"{name}-{human}.db"
    serve_cell(load_scenario(name), CellConfig(human=human, store=store))
    return store


def _comparable(events: list[StoredEvent]) -> list[tuple[Any, ...]]:
    """The events without what makes the fork a run of its own (its run id, the ``fork`` and
    the pace of its start) and without the closing summary (wall-clock figures)."""
    drop = {"run", "fork", "realtime"}
    return [
        (ev.seq, ev.kind, ev.t, {k: v for k, v in ev.body.items() if k not in drop})
        for ev in events
        if ev.kind != "summary"
    ]


# the table with a passive operator; the kitchen drawer with an operator that acts on its own
# (options and intents in the store)
@pytest.mark.parametrize(
    ("name", "human"), [("table_assembly", "passive"), ("kitchen_drawer", "takeover")]
)
def test_a_fork_with_the_stored_choices_reproduces_the_run_to_its_end(
    tmp_path: Path, name: str, human: str
) -> None:
    source = _stored(tmp_path, name, human)
    events = read_store(source)
    end = next(ev.seq for ev in events if ev.kind == "outcome")
    middle = next(ev.seq for ev in events[len(events) // 2 :] if ev.kind == "command")
    # after every command too: a fork after a command and before the ``options`` of the same
    # input once lost those options (the resume recorded the outputs of the last stored input
    # only up to its first command)
    commands = [ev.seq for ev in events if ev.kind == "command"]
    points = sorted({1, middle, end - 1, *(commands if human == "takeover" else ())})
    for at in points:
        out = tmp_path / f"fork{at}.db"
        report = fork_store(source, at, out, scenario=_load)
        forked = read_store(out)
        assert _comparable(forked) == _comparable(events), at
        # a run of its own, which says where it comes from
        assert forked[0].body["run"] != events[0].body["run"]
        assert forked[0].body["fork"] == {
            "run": events[0].body["run"],
            "at": at,
            "store": str(source),
        }
        assert len({ev.body["run"] for ev in forked}) == 1
        assert report.fork["by_agent"] == report.original["by_agent"]
        assert report.fork["timing"]["total_s"] == report.original["timing"]["total_s"]
        # the fork reads back as a store of its own (replay) and forks again
        assert summarise_store(out)[0]["outcome"] == "solved"
    again = fork_store(
        tmp_path / f"fork{middle}.db", middle + 2, tmp_path / "again.db", scenario=_load
    )
    assert _comparable(read_store(tmp_path / "again.db")) == _comparable(events)
    assert again.fork["by_agent"] == again.original["by_agent"]


def test_a_fork_with_another_operator_differs_and_both_summaries_print(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    source = _stored(tmp_path, "table_assembly", "takeover")
    out = tmp_path / "passive.db"
    assert (
        main(["replay", str(source), "--fork-at", "20", "--human", "passive", "-o", str(out)]) == 0
    )
    text = capsys.readouterr().out
    assert "stored run" in text and "what-if (from event 20)" in text
    assert "human: takeover" in text and "human: passive" in text
    for row in ("makespan", "by human", "by left", "by right", "person's share"):
        assert row in text
    original, _ = summarise_store(source)
    forked, _ = summarise_store(out)
    assert forked["outcome"] == "solved"
    assert forked["by_agent"] != original["by_agent"]  # the passive person took fewer steps
    assert forked["by_agent"]["human"] < original["by_agent"]["human"]
    # the stored events up to K are the fork's, and the new choice is a stored input after them
    events, forked_events = read_store(source), read_store(out)
    assert _comparable(forked_events[:20]) == _comparable(events[:20])
    first = next(ev for ev in forked_events[20:] if ev.is_input)  # after the outputs of K's
    assert (first.kind, first.body["profile"]) == ("operator", "passive")
    # the JSON: both runs' figures
    again = tmp_path / "again.db"
    argv = ["replay", str(source), "--fork-at", "20", "--human", "passive", "-o", str(again)]
    assert main([*argv, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["fork_at"] == 20 and data["fork_t"] == events[19].t
    assert data["original"]["by_agent"] == original["by_agent"]
    assert data["fork"]["by_agent"] == forked["by_agent"]
    assert data["original"]["makespan_s"] == original["timing"]["total_s"]
    assert 0 <= data["fork"]["person_share"] < data["original"]["person_share"] <= 1
    assert data["profiles"]["fork"] == {"human": "passive"}


def test_a_what_if_store_replays_its_new_choice(tmp_path: Path) -> None:
    """The new profile is a stored input: the what-if's own store, forked again after it with
    the choices it holds, goes on as the what-if did, event for event."""
    source = _stored(tmp_path, "table_assembly", "takeover")
    first = tmp_path / "passive.db"
    fork_store(source, 20, first, scenario=_load, human="passive")
    events = read_store(first)
    choice = next(ev.seq for ev in events if ev.kind == "operator" and ev.seq > 20)
    for at in (choice, choice + 3):
        again = tmp_path / f"again{at}.db"
        report = fork_store(first, at, again, scenario=_load)
        assert report.profiles["fork"] == {"human": "passive"}
        assert _comparable(read_store(again)) == _comparable(events), at


def test_a_what_if_under_another_failure_policy(tmp_path: Path) -> None:
    source = _stored(tmp_path, "kitchen_drawer", "passive")
    assert read_store(source)[0].body["on_failure"] == "retry"
    out = tmp_path / "paper.db"
    report = fork_store(source, 4, out, scenario=_load, on_failure="paper")
    assert read_store(out)[0].body["on_failure"] == "paper"
    assert report.fork["on_failure"] == "paper" and report.original["on_failure"] == "retry"
    assert report.fork["outcome"] == "solved"


def test_a_passive_operator_from_a_takeover_one_at_every_event_ends_solved(tmp_path: Path) -> None:
    """An operator that was deciding on ``options`` when the fork made it passive is not
    waited for (its open options are dropped with the stored ``operator`` input)."""
    source = _stored(tmp_path, "kitchen_drawer", "takeover")
    events = read_store(source)
    asked = [ev.seq for ev in events if ev.kind == "options"][:3]
    assert asked
    for at in asked:
        report = fork_store(source, at, tmp_path / f"p{at}.db", scenario=_load, human="passive")
        assert report.fork["outcome"] == "solved", at


def test_fork_plot_draws_both_timelines(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("matplotlib")
    source = _stored(tmp_path, "table_assembly", "takeover")
    png = tmp_path / "both.png"
    argv = ["replay", str(source), "--fork-at", "20", "--human", "passive", "--plot", str(png)]
    assert main(argv) == 0
    assert png.stat().st_size > 0
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # written atomically
    capsys.readouterr()


def test_what_if_errors_are_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    source = _stored(tmp_path, "kitchen_drawer", "passive")
    events = read_store(source)
    end = next(ev.seq for ev in events if ev.kind == "outcome")

    def fails(*argv: str) -> str:
        assert main(["replay", str(source), *argv]) == 2
        err = capsys.readouterr().err
        assert err.startswith("error: ") and err.count("\n") == 1, err
        return err

    err = fails("--fork-at", str(end))
    assert f"--fork-at {end}: out of range" in err and f"from 1 to {end - 1}" in err
    assert "--fork-at" in fails("--fork-at", "0")
    assert "only with --fork-at" in fails("--human", "takeover")
    assert "only with --fork-at" in fails("-o", str(tmp_path / "x.db"))
    # output paths are checked before any work
    taken = tmp_path / "taken.db"
    taken.write_bytes(b"keep me")
    assert "already exists" in fails("--fork-at", "3", "-o", str(taken))
    assert taken.read_bytes() == b"keep me"
    assert "does not exist" in fails("--fork-at", "3", "-o", str(tmp_path / "no" / "x.db"))
    assert "refusing to overwrite" in fails("--fork-at", "3", "-o", str(source))
    assert "unsupported output format" in fails("--fork-at", "3", "-o", str(tmp_path / "x.txt"))
    if os.geteuid() != 0:  # root writes anywhere
        locked = tmp_path / "locked"
        locked.mkdir()
        locked.chmod(0o500)
        try:
            assert "cannot write" in fails("--fork-at", "3", "-o", str(locked / "x.db"))
        finally:
            locked.chmod(0o700)
    assert read_store(source) == events  # the stored run is never touched
    # --force replaces an existing file with the what-if
    assert main(["replay", str(source), "--fork-at", "3", "-o", str(taken), "--force"]) == 0
    capsys.readouterr()
    assert summarise_store(taken)[0]["outcome"] == "solved"
    # a JSON-lines log cannot be forked
    log = tmp_path / "run.jsonl"
    assert main(["run", "kitchen_drawer", "--log", str(log), "--quiet"]) == 0
    capsys.readouterr()
    assert main(["replay", str(log), "--fork-at", "2"]) == 2
    assert "not a cell's event store" in capsys.readouterr().err


def test_a_run_of_a_scenario_file_forks_with_its_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = Path(__file__).parents[2] / "examples" / "scenarios" / "ball_in_box.yaml"
    source = tmp_path / "ball.db"
    serve_cell(load_scenario(path), CellConfig(store=source))
    out = tmp_path / "fork.db"
    assert main(["replay", str(source), "--fork-at", "5", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "is not a shipped one: give its file with --scenario FILE" in err
    assert not out.exists()
    argv = ["replay", str(source), "--fork-at", "5", "-o", str(out), "--scenario", str(path)]
    assert main(argv) == 0
    assert "what-if (from event 5)" in capsys.readouterr().out
    assert _comparable(read_store(out)) == _comparable(read_store(source))
    # another scenario than the stored fingerprint: refused, nothing written
    other = tmp_path / "other.db"
    argv = [
        "replay",
        str(source),
        "--fork-at",
        "5",
        "-o",
        str(other),
        "--scenario",
        "kitchen_drawer",
    ]
    assert main(argv) == 2
    assert "give it with --scenario FILE" in capsys.readouterr().err
    assert not other.exists()


def test_a_run_with_an_operator_model_forks_with_its_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The store keeps the operator model (flexhrc learn) the manager timed the person by in
    its ``start`` (``operator_model``): the fork reproduces the run with ``--operators`` and
    without it. A store from before that key does not hold the model: without the file its
    first K events do not replay as stored, refused with nothing written."""
    first = _stored(tmp_path, "kitchen_drawer", "passive")
    model = tmp_path / "operators.yaml"
    assert main(["learn", str(first), "-o", str(model)]) == 0
    source = tmp_path / "modelled.db"
    serve_cell(load_scenario("kitchen_drawer"), CellConfig(store=source, operators=model))
    out = tmp_path / "fork.db"
    argv = ["replay", str(source), "--fork-at", "30", "-o", str(out), "--operators", str(model)]
    assert main(argv) == 0
    capsys.readouterr()
    assert _comparable(read_store(out)) == _comparable(read_store(source))
    late = next(ev.seq for ev in read_store(source)[::-1] if ev.kind == "command")
    stored = tmp_path / "stored.db"  # the model from the store's start, no file
    assert main(["replay", str(source), "--fork-at", str(late), "-o", str(stored)]) == 0
    capsys.readouterr()
    assert _comparable(read_store(stored)) == _comparable(read_store(source))
    older = tmp_path / "older.db"  # as written before the start kept the model
    with EventStore(older) as store:
        for ev in read_store(source):
            body = {k: v for k, v in ev.body.items() if k != "operator_model"}
            store.append(ev.kind, body, ev.t)
    bad = tmp_path / "bad.db"
    assert main(["replay", str(older), "--fork-at", str(late), "-o", str(bad)]) == 2
    assert "give it with --operators FILE" in capsys.readouterr().err
    assert not [p for p in tmp_path.iterdir() if p.name.startswith("bad.db")]


def test_a_fork_with_another_utility_differs_and_its_store_replays_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--utility FILE`` (issue 22, item 5): from event K the Task Manager scores branches by
    the file's utility — here the person is preferred for every step they may do — stored as
    the input ``utility``, so the fork's own store resumes and replays it. The gearbox
    example: the person may mount, fasten and cover as the arms may (the table's person only
    checks, so no utility changes who does what there)."""
    gearbox = str(Path(__file__).parents[2] / "examples" / "scenarios" / "gearbox.yaml")
    source = tmp_path / "gearbox.db"
    serve_cell(load_scenario(gearbox), CellConfig(human="passive", store=source))
    events = read_store(source)
    at = next(ev.seq for ev in events if ev.kind == "command")
    prefer = tmp_path / "prefer_person.yaml"
    prefer.write_text("utility:\n  preference: 3.0\n  prefer: {human: 1.0}\n")
    out = tmp_path / "fork.db"
    code = main(["replay", str(source), "--fork-at", str(at), "--utility", str(prefer),
                 "--scenario", gearbox, "-o", str(out), "--json"])  # fmt: skip
    assert code == 0
    data = json.loads(capsys.readouterr().out)
    stored, forked = read_store(source), read_store(out)
    [changed] = [ev for ev in forked if ev.kind == "utility"]
    assert changed.seq == at + 1 and changed.body["utility"]["prefer"] == {"human": 1.0}
    assert _comparable(forked[:at]) == _comparable(stored[:at])
    humans = data["summaries"]["fork"]["by_agent"].get("human", 0)
    assert humans > data["summaries"]["original"]["by_agent"].get("human", 0), data["summaries"]
    # the fork's own store replays its new utility: a fork of it with no new choice is itself
    again = tmp_path / "again.db"
    report = fork_store(out, len(forked) - 2, again, scenario=load_scenario(gearbox))
    assert _comparable(read_store(again)) == _comparable(forked)
    assert report.fork["by_agent"] == report.original["by_agent"]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("utility:\n  preference: -1\n", ":2: "),
        ("utility:\n  prefer: {nobody: 1.0}\n", "--utility: "),
        ("- 1\n", "give a utility block"),
    ],
)
def test_a_bad_utility_file_is_one_error_and_no_store(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, message: str
) -> None:
    source = _stored(tmp_path, "table_assembly", "passive")
    bad = tmp_path / "bad.yaml"
    bad.write_text(text)
    out = tmp_path / "fork.db"
    assert (
        main(["replay", str(source), "--fork-at", "5", "--utility", str(bad), "-o", str(out)]) == 2
    )
    err = capsys.readouterr().err
    assert err.startswith("error: ") and message in err and len(err.strip().splitlines()) == 1, err
    assert not out.exists()
