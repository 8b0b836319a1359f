"""An operator model learned from the event store (issue 22, item 4).

``flexhrc learn STORE... -o operators.yaml`` reads what each person took per action from cell
stores; ``--operators`` on ``run`` and ``cell`` makes the Task Manager time that person's steps
by it (and update it online as they act), so its decisions change.
"""

from __future__ import annotations

import importlib.util
import json
import statistics
import sys
from pathlib import Path

import pytest

from flexhrc.cell.local import LocalCell
from flexhrc.cell.store import EventStore, read_store
from flexhrc.cli import main
from flexhrc.errors import FormatError
from flexhrc.scenario import load_scenario
from flexhrc.taskmanager.operator_model import (
    OperatorModel,
    OperatorModelSimulator,
    read_model,
    write_model,
)
from flexhrc.taskmanager.simulator import AnalyticSimulator

ROOT = Path(__file__).resolve().parents[2]


def _bench():
    """benchmarks/operators.py: its workbench scenario and its person who differs."""
    spec = importlib.util.spec_from_file_location(
        "bench_operators", ROOT / "benchmarks/operators.py"
    )
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("bench_operators", module)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def bench():
    return _bench()


@pytest.fixture
def workbench(tmp_path, bench) -> Path:
    path = tmp_path / "workbench.yaml"
    path.write_text(bench.SCENARIO)
    return path


def _stored_run(path: Path, db: Path, bench, *, case: str = "slow", seed: int = 0) -> None:
    """One cooperation of a person 40 % slower at ``fasten``, kept in the store ``db``."""
    scenario = load_scenario(path)
    world = bench.RealPerson(AnalyticSimulator(), bench.CASES[case], seed)
    with EventStore(db) as store:
        result = LocalCell(
            scenario, simulator=AnalyticSimulator(), execution=world, seed=seed, store=store
        ).run()
    assert result.outcome == "solved"


def _who_did(doc: dict, hyperarc: str) -> str:
    return next(s["agent"] for s in doc["solved_hyperarcs"] if s["hyperarc"] == hyperarc)


def test_learns_each_persons_durations_from_a_store(tmp_path, workbench, bench, capsys):
    db = tmp_path / "run.db"
    _stored_run(workbench, db, bench)
    took: dict[str, list[float]] = {}
    for ev in read_store(db):
        if ev.kind == "human_action":
            took.setdefault(ev.body["action"].split("(")[0], []).append(
                ev.body["t"] - ev.body["start"]
            )
    assert "fasten" in took  # the defaults ask the person to fasten
    asked = sum(1 for ev in read_store(db) if ev.kind == "suggestion")

    out = tmp_path / "operators.yaml"
    assert main(["learn", str(db), "-o", str(out), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    person = doc["persons"]["human"]
    for action, samples in took.items():
        est = person["actions"][action]
        assert est["n"] == len(samples)
        assert est["median_s"] == pytest.approx(statistics.median(samples), abs=1e-3)
    # the person is 40 % slower at fastening than the scenario's 5 s + travel
    assert person["actions"]["fasten"]["median_s"] > 1.3 * 5.0
    assert person["suggestions"] == asked
    # no decline/cannot answers in this store: the rates are there, at 0
    assert person["declined"] == person["cannot"] == 0
    assert person["decline_rate"] == person["cannot_rate"] == 0.0
    assert read_model(out).to_dict() == {k: v for k, v in doc.items() if k != "output"}


def test_the_file_round_trip(tmp_path):
    model = OperatorModel()
    for s in (6.5, 7.25, 7.0):
        model.observe("human", "fasten", s)
    model.observe("human", "insert_pin", 2.0)
    model.person("human").suggestions = 4
    model.person("human").declined = 1
    path = tmp_path / "operators.yaml"
    write_model(model, path)
    back = read_model(path)
    assert back.to_dict() == model.to_dict()
    est = back.estimate("human", "fasten")
    assert est is not None and est.median_s == 7.0 and est.spread_s == 0.25
    assert back.person("human").decline_rate == 0.25
    # an entry written by hand: n and median only, looked up by the action's kind as well
    path.write_text(
        "flexhrc_operators: 1\npersons:\n  human:\n    actions:\n      screw: {n: 3, median_s: 9}\n"
    )
    hand = read_model(path)
    assert hand.estimate("human", "fasten") is None
    est = hand.estimate("human", "fasten", "screw")
    assert est is not None and est.n == 3 and est.median_s == 9.0


@pytest.mark.parametrize(
    ("text", "line", "words"),
    [
        ("persons: {}\n", 1, "flexhrc_operators must be 1"),
        ("flexhrc_operators: 1\npersons:\n  human:\n    speed: 3\n", 4, "unknown key 'speed'"),
        (
            "flexhrc_operators: 1\npersons:\n  human:\n    actions:\n      screw:\n"
            "        median_s: -1\n",
            6,
            "median_s must be seconds >= 0",
        ),
        (
            "flexhrc_operators: 1\npersons:\n  human:\n    suggestions: 1\n    declined: 2\n",
            5,
            "more answers",
        ),
        ("flexhrc_operators: 1\npersons: {a: [1}\n", 2, "YAML syntax error"),
        (
            "flexhrc_operators: 1\npersons:\n  human:\n    answers:\n      carry:\n"
            "        suggestions: 1\n        cannot: 2\n",
            7,
            "person human, answers carry: more answers",
        ),
        (
            "flexhrc_operators: 1\npersons:\n  human:\n    answers:\n      carry: {asked: 1}\n",
            5,
            "unknown key 'asked'",
        ),
    ],
)
def test_a_bad_file_is_one_error_with_its_line(tmp_path, capsys, text, line, words):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(FormatError) as err:
        read_model(path)
    assert err.value.line == line and words in str(err.value)
    assert main(["run", "ball_in_box", "--operators", str(path), "--quiet"]) == 2
    assert capsys.readouterr().err.strip() == f"error: {path}:{line}: {err.value.message}"


def test_learn_checks_its_output_before_reading(tmp_path, capsys):
    missing = tmp_path / "missing.db"
    assert main(["learn", str(missing), "-o", str(tmp_path / "model.txt")]) == 2
    assert "-o" in capsys.readouterr().err  # the output is refused first
    assert main(["learn", str(missing), "-o", str(tmp_path / "model.yaml")]) == 2
    assert "missing.db: no such file" in capsys.readouterr().err
    assert not (tmp_path / "model.yaml").exists()


def test_operators_changes_a_decision_in_run_and_cell(tmp_path, workbench, capsys):
    model = OperatorModel()
    for _ in range(3):
        model.observe("human", "fasten", 9.0)  # far slower than the scenario's 5 s + travel
    path = tmp_path / "operators.yaml"
    write_model(model, path)
    base = ["run", str(workbench), "--json", "--quiet"]
    assert main(base) == 0
    default = json.loads(capsys.readouterr().out)
    assert _who_did(default, "fasten_1") == "human"
    assert main([*base, "--operators", str(path)]) == 0
    learned = json.loads(capsys.readouterr().out)
    assert _who_did(learned, "fasten_1") == "arm"
    assert learned["operator_model"]["file"] == str(path)

    db = tmp_path / "cell.db"
    argv = ["cell", str(workbench), "--operators", str(path), "--store", str(db)]
    assert main([*argv, "--json", "--quiet"]) == 0
    capsys.readouterr()
    first = next(ev for ev in read_store(db) if ev.kind == "decision")
    assert first.body["element"] == "fasten_1"
    chosen = first.body["branches"][first.body["chosen"]]
    assert chosen["agents"] == ["arm"]
    person = next(b for b in first.body["branches"] if b["agents"] == ["human"])
    assert person["durations"] == [9.0]  # the person's branch is timed by the model


def test_the_model_updates_online_as_the_person_acts(workbench, bench):
    """Starting from an empty model, the first fasten goes to the person (the scenario's
    figures); once they took 40 % longer, the next fasten goes to the arm."""
    scenario = load_scenario(workbench)
    world = bench.RealPerson(AnalyticSimulator(), bench.CASES["slow"], 0)
    manager = OperatorModelSimulator(AnalyticSimulator(), OperatorModel())
    result = LocalCell(scenario, simulator=manager, execution=world, seed=0).run()
    assert result.outcome == "solved"
    solved = {s["hyperarc"]: s["agent"] for s in result.summary["solved_hyperarcs"]}
    assert solved["fasten_1"] == "human"
    assert solved["fasten_2"] == solved["fasten_3"] == "arm"
    est = manager.model.estimate("human", "fasten")
    assert est is not None and est.n == 1
    assert est.median_s == pytest.approx(world.took["fasten"][0])

    # without the model the person keeps fastening
    plain = LocalCell(
        scenario,
        simulator=AnalyticSimulator(),
        execution=bench.RealPerson(AnalyticSimulator(), bench.CASES["slow"], 0),
        seed=0,
    ).run()
    assert {s["hyperarc"]: s["agent"] for s in plain.summary["solved_hyperarcs"]}["fasten_2"] == (
        "human"
    )


def test_the_online_update_replays_on_resume(tmp_path, workbench, bench):
    """The update is fed by the stored ``human_action`` inputs, so a resumed cell rebuilds the
    model from the store: cut a run right after the slow person's first fasten, resume it with
    an empty model, and the next fasten still goes to the arm."""
    from flexhrc.cell.serve import CellConfig, serve_cell

    scenario = load_scenario(workbench)
    full = tmp_path / "full.db"
    with EventStore(full) as store:
        LocalCell(
            scenario,
            simulator=OperatorModelSimulator(AnalyticSimulator(), OperatorModel()),
            execution=bench.RealPerson(AnalyticSimulator(), bench.CASES["slow"], 0),
            store=store,
        ).run()
    events = read_store(full)
    cut = next(
        i
        for i, ev in enumerate(events)
        if ev.kind == "human_action" and "fasten" in ev.body["action"]
    )
    crashed = tmp_path / "crashed.db"
    with EventStore(crashed) as store:
        for ev in events[: cut + 1]:
            store.append(ev.kind, ev.body, ev.t)
    empty = tmp_path / "empty.yaml"
    write_model(OperatorModel(), empty)
    data = serve_cell(scenario, CellConfig(store=crashed, resume=True, operators=empty))
    assert data["outcome"] == "solved"
    solved = {
        ev.body["element"]: ev.body["agents"] for ev in read_store(crashed) if ev.kind == "solved"
    }
    assert solved["fasten_1"] == ["human"]
    assert solved["fasten_2"] == ["arm"]


def test_declines_and_cannots_are_counted_per_person():
    """The person's ``human_reply`` inputs (issue 22, item 1): "not now" and "I can't" against
    the suggestions they got; a resent reply counts once, a ``start`` is no answer."""
    from flexhrc.cell.store import StoredEvent
    from flexhrc.taskmanager.operator_model import learn_events

    def ev(seq: int, kind: str, **body) -> StoredEvent:
        return StoredEvent(seq, float(seq), kind, {"run": "r", **body})

    events = [
        ev(1, "suggestion", id="s1", agent="human", actions=["fasten(human, screw_1)"]),
        ev(2, "human_reply", id="h1", agent="human", reply="decline", suggestion="s1"),
        ev(3, "human_reply", id="h1", agent="human", reply="decline", suggestion="s1"),
        ev(4, "suggestion", id="s2", agent="human", actions=["fasten(human, screw_1)"]),
        ev(5, "human_reply", id="h2", agent="human", reply="cannot", suggestion="s2"),
        ev(6, "suggestion", id="s3", agent="human", actions=["insert_pin(human, pin_1)"]),
        ev(7, "human_reply", id="h3", agent="human", reply="start", suggestion="s3"),
        ev(8, "suggestion", id="s4", agent="human", actions=["insert_pin(human, pin_2)"]),
    ]
    person = learn_events(events).person("human")
    assert (person.suggestions, person.declined, person.cannot) == (4, 1, 1)
    assert person.decline_rate == person.cannot_rate == 0.25


def _decliner(suggestions: int, declined: int, cannot: int = 0) -> OperatorModel:
    model = OperatorModel()
    person = model.person("human")
    person.suggestions, person.declined, person.cannot = suggestions, declined, cannot
    return model


def _lids(tmp_path: Path):
    from tests.cell.test_answers import LIDS

    path = tmp_path / "lids.yaml"
    path.write_text(LIDS)
    return path


def _first_decision(result) -> dict:
    return next(e for e in result.events if e["type"] == "decision")


def test_a_learned_high_decline_rate_gives_the_step_to_the_arm(tmp_path):
    """The lids: the person is faster (eq. 21: J = 1/2.14 against the arm's 1/4.57), so they
    are asked first. A model in which they declined 6 of 10 requests scores their branch by
    its expected utility J * (1 - 0.6) = 0.187 < 0.219: the arm carries the lids, nobody is
    asked; at 2 of 10 the person is still asked. The decision log shows the terms."""
    scenario = load_scenario(_lids(tmp_path), seed=0)
    plain = LocalCell(scenario, simulator=AnalyticSimulator()).run()
    assert plain.summary["by_agent"] == {"human": 2, "arm": 0}
    assert all("terms" not in b for b in _first_decision(plain)["branches"])  # eq. (21)

    model = OperatorModelSimulator(AnalyticSimulator(), _decliner(10, 6))
    result = LocalCell(scenario, simulator=model).run()
    assert result.outcome == "solved" and result.summary["by_agent"] == {"human": 0, "arm": 2}
    assert not [e for e in result.events if e["type"] == "suggestion"]
    first = _first_decision(result)
    person = next(b for b in first["branches"] if b["agents"] == ["human"])
    arm = next(b for b in first["branches"] if b["agents"] == ["arm"])
    assert person["terms"]["p_decline"] == 0.6 and person["terms"]["p_cannot"] == 0.0
    assert person["utility"] == pytest.approx(0.4 / person["terms"]["time"])
    assert "terms" not in arm and first["branches"][first["chosen"]] is not person
    assert arm["utility"] > person["utility"]

    willing = OperatorModelSimulator(AnalyticSimulator(), _decliner(10, 1, 1))
    asked = LocalCell(scenario, simulator=willing).run()
    assert asked.summary["by_agent"] == {"human": 2, "arm": 0}
    person = next(b for b in _first_decision(asked)["branches"] if b["agents"] == ["human"])
    assert person["terms"]["p_decline"] == person["terms"]["p_cannot"] == 0.1
    assert person["utility"] == pytest.approx(0.8 / person["terms"]["time"])


def test_a_model_without_answers_keeps_eq_21_and_the_cli_shows_the_terms(tmp_path, capsys):
    """A model whose person never declined leaves the decisions and their log as eq. (21)
    has them (the durations it learns as the person acts aside); `flexhrc run --operators` with a decliner prints the terms in its trace."""
    path = _lids(tmp_path)
    scenario = load_scenario(path, seed=0)
    plain = LocalCell(scenario, simulator=AnalyticSimulator()).run()
    quiet = LocalCell(
        scenario, simulator=OperatorModelSimulator(AnalyticSimulator(), _decliner(10, 0))
    ).run()
    decisions = [e for e in quiet.events if e["type"] == "decision"]
    assert decisions and all("terms" not in b for d in decisions for b in d["branches"])
    first, plain_first = decisions[0], _first_decision(plain)
    assert [b["utility"] for b in first["branches"]] == [
        b["utility"] for b in plain_first["branches"]
    ]
    assert quiet.summary["by_agent"] == plain.summary["by_agent"]

    model = tmp_path / "operators.yaml"
    write_model(_decliner(10, 6), model)
    assert main(["run", str(path), "--operators", str(model)]) == 0
    out = capsys.readouterr()
    text = out.out + out.err
    assert "declines 60%, cannot 0%" in text, text


def test_the_model_is_kept_in_the_stored_start_resume_and_fork_need_no_file(tmp_path, capsys):
    """`cell --operators FILE` keeps the model's content in its stored ``start``
    (``operator_model``): a store cut right after its start resumes without the file — and
    still decides by the model (the decliner's lids go to the arm; without the model the
    person would be asked) — and a what-if forks it faithfully without the file."""
    from flexhrc.cell.fork import fork_store
    from flexhrc.cell.serve import CellConfig, serve_cell

    path = _lids(tmp_path)
    model = tmp_path / "operators.yaml"
    write_model(_decliner(10, 6), model)
    db = tmp_path / "cell.db"
    assert main(["cell", str(path), "--operators", str(model), "--store", str(db), "--quiet"]) == 0
    capsys.readouterr()
    events = read_store(db)
    assert events[0].body["operator_model"] == read_model(model).to_dict()

    def solved(store: Path) -> dict:
        return {
            e.body["element"]: e.body["agents"] for e in read_store(store) if e.kind == "solved"
        }

    assert solved(db) == {"place_a": ["arm"], "place_b": ["arm"]}
    model.unlink()  # from here on, only the store knows the model
    cut = tmp_path / "cut.db"
    with EventStore(cut) as store:
        store.append(events[0].kind, events[0].body, events[0].t)
    scenario = load_scenario(path, seed=0)
    assert serve_cell(scenario, CellConfig(store=cut, resume=True))["outcome"] == "solved"
    assert solved(cut) == solved(db)
    person = next(e for e in read_store(cut) if e.kind == "decision").body["branches"][0]
    assert person["agents"] == ["human"] and person["terms"]["p_decline"] == 0.6

    fork = tmp_path / "fork.db"
    fork_store(db, 1, fork, scenario=scenario)
    assert solved(fork) == solved(db)
    assert read_store(fork)[0].body["operator_model"] == events[0].body["operator_model"]


def test_a_stored_model_given_again_and_a_bad_stored_model(tmp_path):
    """``--operators`` on a resume decides (the option's file, not the stored copy); a stored
    model that is not one is one error naming the stored start."""
    from flexhrc.cell.serve import CellConfig, serve_cell

    path = _lids(tmp_path)
    scenario = load_scenario(path, seed=0)
    decliner = tmp_path / "decliner.yaml"
    write_model(_decliner(10, 6), decliner)
    willing = tmp_path / "willing.yaml"
    write_model(_decliner(10, 0), willing)
    first = tmp_path / "first.db"
    serve_cell(scenario, CellConfig(store=first, operators=decliner))
    start = read_store(first)[0]
    again = tmp_path / "again.db"
    with EventStore(again) as store:
        store.append(start.kind, start.body, start.t)
    serve_cell(scenario, CellConfig(store=again, resume=True, operators=willing))
    firsts = [e.body for e in read_store(again) if e.kind == "solved"]
    assert firsts[0]["agents"] == ["human"]  # the given model: the person is asked

    bad = tmp_path / "bad.db"
    with EventStore(bad) as store:
        store.append(start.kind, {**start.body, "operator_model": {"persons": 3}}, start.t)
    with pytest.raises(FormatError, match="stored start: operator_model"):
        serve_cell(scenario, CellConfig(store=bad, resume=True))


def test_declines_and_cannots_are_counted_per_action_too():
    """Each request's action names count it (``answers``), and its reply counts for them."""
    from flexhrc.cell.store import StoredEvent
    from flexhrc.taskmanager.operator_model import learn_events

    def ev(seq: int, kind: str, **body) -> StoredEvent:
        return StoredEvent(seq, float(seq), kind, {"run": "r", **body})

    events = [
        ev(1, "suggestion", id="s1", agent="human", actions=["fasten(human, screw_1)"]),
        ev(2, "human_reply", id="h1", agent="human", reply="decline", suggestion="s1"),
        ev(
            3,
            "suggestion",
            id="s2",
            agent="human",
            actions=["pick(human, screw_2)", "fasten(human, screw_2)"],
        ),
        ev(4, "human_reply", id="h2", agent="human", reply="cannot", suggestion="s2"),
        ev(5, "suggestion", id="s3", agent="human", actions=["insert_pin(human, pin_1)"]),
    ]
    person = learn_events(events).person("human")
    counts = {a: (c.suggestions, c.declined, c.cannot) for a, c in person.answers.items()}
    assert counts == {"fasten": (2, 1, 1), "pick": (1, 0, 1), "insert_pin": (1, 0, 0)}
    assert person.rates("fasten") == (0.5, 0.5) and person.rates("insert_pin") == (0.0, 0.0)
    assert person.rates("screw") == (pytest.approx(1 / 3), pytest.approx(1 / 3))  # never asked
    doc = OperatorModel(persons={"human": person}).to_dict()["persons"]["human"]["answers"]
    assert doc["fasten"] == {"suggestions": 2, "declined": 1, "cannot": 1,
                             "decline_rate": 0.5, "cannot_rate": 0.5}  # fmt: skip


def test_an_i_cannot_learned_from_a_store_keeps_the_person_from_that_action(tmp_path):
    """A run in which the person said "I can't" to carrying a lid, learned: in the next run
    the carries' expected utility is 0 for the person (their cannot rate for ``carry`` is 1,
    though over all their requests it is lower), so nobody asks them. The model's file keeps
    the per-action counts and reads back the same."""
    from flexhrc.taskmanager.operator_model import learn_events

    scenario = load_scenario(_lids(tmp_path), seed=0)
    db = tmp_path / "first.db"
    with EventStore(db) as store:
        first = LocalCell(
            scenario,
            simulator=AnalyticSimulator(),
            replies=lambda el, actions, k: ("cannot", "no gloves") if el == "place_a" else None,
            store=store,
        ).run()
    assert first.outcome == "solved"
    model = learn_events(read_store(db))
    person = model.person("human")
    assert person.rates("carry") == (0.0, 1.0)
    path = tmp_path / "operators.yaml"
    write_model(model, path)
    assert read_model(path).to_dict() == model.to_dict()

    again = LocalCell(scenario, simulator=OperatorModelSimulator(AnalyticSimulator(), model)).run()
    assert again.outcome == "solved" and again.summary["by_agent"] == {"human": 0, "arm": 2}
    assert not [e for e in again.events if e["type"] == "suggestion"]
    branch = next(b for b in _first_decision(again)["branches"] if b["agents"] == ["human"])
    assert branch["terms"]["p_cannot"] == 1.0 and branch["utility"] == 0.0
