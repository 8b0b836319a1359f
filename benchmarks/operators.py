"""The operator model learned from the store (issue 22, item 4): makespan with it vs the defaults.

A workbench: one robot arm and one operator fasten three screws and insert three pins, in any
order, then one of them checks the work. The scenario's figures make the operator the quicker at
both kinds of action (they stand at the bench; the arm travels). The *simulated* operators are
not the scenario's nominal person (their real durations carry a seeded ±10 % noise besides):

* ``slow`` — 40 % slower at ``fasten`` than the scenario says (so the arm is really quicker);
* ``fast`` — 40 % faster at ``insert_pin`` than the scenario says.

For each case and each of 20 seeds: three runs with the scenario's defaults are stored
(``EventStore``, as ``flexhrc cell --store`` writes them); ``flexhrc learn``'s
:func:`~flexhrc.app.learn.learn_model` learns the model from those three stores;
then one more run (seed as given) with the defaults and one with the learned model
(``--operators``: the Task Manager times the person's steps by it, updated online). Medians over
the seeds; the estimate's error after the three runs is printed against the person's true
median duration (measured over the evaluation runs).

Acceptance (issue 22): the learned model's median makespan is lower than the defaults' for the
slow-person case. In the fast case the scenario's figures already give the person every pin
(they are the quicker even by the scenario), so the learned model only makes the estimate right
and no decision changes: a model learns from what the person did, and a step the defaults
never give them leaves nothing in the store to learn from.

    python benchmarks/operators.py [--seeds 20] [--runs 3]
"""

from __future__ import annotations

import argparse
import random
import statistics
import sys
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from flexhrc.app.learn import learn_model
from flexhrc.cell.local import LocalCell
from flexhrc.cell.store import EventStore
from flexhrc.knowledge import KnowledgeBase
from flexhrc.scenario import load_scenario
from flexhrc.taskmanager.domain import Domain, GroundAction
from flexhrc.taskmanager.operator_model import (
    OperatorModel,
    OperatorModelSimulator,
    write_model,
)
from flexhrc.taskmanager.simulator import AnalyticSimulator, StepReport

SCENARIO = """\
flexhrc: 1
name: workbench
description: One arm and one operator fasten three screws and insert three pins, then check.
graphs:
  bench:
    root: checked
    nodes:
      - {name: start, state: "loose(screw_1)"}
      - {name: screw_1_in, state: "fastened(screw_1)"}
      - {name: pin_1_in, state: "inserted(pin_1)"}
      - {name: screw_2_in, state: "fastened(screw_2)"}
      - {name: pin_2_in, state: "inserted(pin_2)"}
      - {name: screw_3_in, state: "fastened(screw_3)"}
      - {name: pin_3_in, state: "inserted(pin_3)"}
      - {name: checked, state: "checked(bench)"}
    hyperarcs:
      - {name: fasten_1, children: [start], parent: screw_1_in,
         actions: ["fasten(?who, screw_1)"]}
      - {name: pin_1, children: [screw_1_in], parent: pin_1_in,
         actions: ["insert_pin(?who, pin_1)"]}
      - {name: fasten_2, children: [pin_1_in], parent: screw_2_in,
         actions: ["fasten(?who, screw_2)"]}
      - {name: pin_2, children: [screw_2_in], parent: pin_2_in,
         actions: ["insert_pin(?who, pin_2)"]}
      - {name: fasten_3, children: [pin_2_in], parent: screw_3_in,
         actions: ["fasten(?who, screw_3)"]}
      - {name: pin_3, children: [screw_3_in], parent: pin_3_in,
         actions: ["insert_pin(?who, pin_3)"]}
      - {name: check, children: [pin_3_in], parent: checked,
         actions: ["check(?who, bench)"]}
domain:
  agents:
    human: {kind: human, types: [human], hand: [0.85, 0.0, 0.1], speed: 0.25}
    arm: {kind: robot, types: [arm], base: [0.0, 0.0, 0.433], rest: [0.307, 0.0, 0.587], reach: 1.2}
  actions:
    fasten:
      parameters: {"?who": agent, "?s": screw}
      agents: {choice: "?who"}
      kind: screw
      pre: ["loose(?s)"]
      add: ["fastened(?s)"]
      delete: ["loose(?s)"]
      moves_to: "?s"
      duration: 5.0
    insert_pin:
      parameters: {"?who": agent, "?p": pin}
      agents: {choice: "?who"}
      kind: insert
      pre: ["out(?p)"]
      add: ["inserted(?p)"]
      delete: ["out(?p)"]
      moves_to: "?p"
      duration: 3.0
    check:
      parameters: {"?who": agent, "?b": bench}
      agents: {choice: "?who"}
      kind: check
      add: ["checked(?b)"]
      moves_to: "?b"
      duration: 1.0
    rest:
      parameters: {"?arm": arm}
      agents: {choice: "?arm"}
      kind: rest
world:
  objects:
    bench: {type: bench, position: [0.6, 0.0, 0.0], size: [0.4, 0.6, 0.02]}
    screw_1: {type: screw, position: [0.75, -0.2, 0.05], size: [0.01, 0.01, 0.02]}
    screw_2: {type: screw, position: [0.75, 0.0, 0.05], size: [0.01, 0.01, 0.02]}
    screw_3: {type: screw, position: [0.75, 0.2, 0.05], size: [0.01, 0.01, 0.02]}
    pin_1: {type: pin, position: [0.35, -0.25, 0.05], size: [0.01, 0.01, 0.03]}
    pin_2: {type: pin, position: [0.35, 0.05, 0.05], size: [0.01, 0.01, 0.03]}
    pin_3: {type: pin, position: [0.35, 0.25, 0.05], size: [0.01, 0.01, 0.03]}
  facts: ["loose(screw_1)", "loose(screw_2)", "loose(screw_3)", "out(pin_1)", "out(pin_2)",
          "out(pin_3)"]
humans:
  - {name: human, profile: passive}
simulator: analytic
"""

#: case -> (action -> how much longer the real person takes than the scenario says)
CASES: dict[str, dict[str, float]] = {
    "slow": {"fasten": 1.4},  # 40 % slower at fastening
    "fast": {"insert_pin": 0.6},  # 40 % faster at inserting pins
}
NOISE = 0.10  # the real person's seeded spread around their own speed


class RealPerson:
    """The simulated real world, with a person whose speed differs from the scenario's: each
    human action takes ``factors[action]`` times the analytic time, times a seeded noise."""

    def __init__(self, inner: AnalyticSimulator, factors: Mapping[str, float], seed: int) -> None:
        self.inner = inner
        self.factors = dict(factors)
        self.rng = random.Random(seed)
        self.took: dict[str, list[float]] = {}  # action -> the person's real durations

    def execute(
        self,
        action: GroundAction,
        positions: dict[str, Any],
        kb: KnowledgeBase,
        domain: Domain,
    ) -> StepReport:
        report = self.inner.execute(action, positions, kb, domain)
        if any(domain.agent(a).is_human for a in action.agents):
            noise = self.rng.uniform(1 - NOISE, 1 + NOISE)
            report.duration_s *= self.factors.get(action.name, 1.0) * noise
            self.took.setdefault(action.name, []).append(report.duration_s)
        return report


def one_run(
    scenario: Any,
    case: str,
    seed: int,
    model: OperatorModel | None,
    store: Path | None = None,
) -> tuple[float, RealPerson]:
    """One cooperation; its makespan and the real person (their durations)."""
    world = RealPerson(AnalyticSimulator(), CASES[case], seed)
    manager: Any = AnalyticSimulator()
    if model is not None:
        manager = OperatorModelSimulator(manager, model)
    st = EventStore(store) if store is not None else None
    try:
        cell = LocalCell(scenario, simulator=manager, execution=world, seed=seed, store=st)
        result = cell.run()
    finally:
        if st is not None:
            st.close()
    if result.outcome != "solved":
        raise SystemExit(f"{case} seed {seed}: {result.outcome} ({result.reason})")
    return float(result.summary["timing"]["total_s"]), world


def default_estimate(scenario: Any, action: str) -> float:
    """What the scenario says the person takes for ``action`` (its first such step)."""
    from flexhrc.cell.components import ground

    kb = scenario.world()
    for text in ("fasten(human, screw_2)", "insert_pin(human, pin_2)"):
        if text.startswith(action):
            sim = AnalyticSimulator().simulate([ground(scenario.domain, text)], kb, scenario.domain)
            return sim.total_s
    raise KeyError(action)


def main() -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--runs", type=int, default=3, help="stored runs to learn from, per seed")
    args = ap.parse_args()
    ok = True
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "workbench.yaml"
        path.write_text(SCENARIO)
        scenario = load_scenario(path)
        print(
            f"workbench (1 arm, 1 passive operator), {args.seeds} seeds, model learned from "
            f"{args.runs} stored runs; medians"
        )
        head = (
            f"{'case':<6}{'defaults s':>12}{'learned s':>11}{'gain':>8}   "
            f"{'action':<11}{'scenario s':>11}{'learned s':>10}{'true s':>8}{'error':>8}"
        )
        print(head)
        print("-" * len(head))
        for case, factors in CASES.items():
            action = next(iter(factors))
            defaults, learned, errors, estimates, truths = [], [], [], [], []
            for seed in range(args.seeds):
                stores = []
                for k in range(args.runs):  # the cooperation as it went, stored
                    db = Path(tmp) / f"{case}-{seed}-{k}.db"
                    one_run(scenario, case, 1000 * (k + 1) + seed, None, db)
                    stores.append(db)
                model = learn_model(stores)
                write_model(model, Path(tmp) / f"{case}-{seed}.yaml")  # the file round trip
                est = model.estimate("human", action)
                m_default, world_d = one_run(scenario, case, seed, None)
                m_learned, world_l = one_run(scenario, case, seed, model)
                defaults.append(m_default)
                learned.append(m_learned)
                took = world_d.took.get(action, []) + world_l.took.get(action, [])
                if est is not None and took:
                    truth = statistics.median(took)
                    estimates.append(est.median_s)
                    truths.append(truth)
                    errors.append(abs(est.median_s - truth) / truth)
            d, lrn = statistics.median(defaults), statistics.median(learned)
            scen = default_estimate(scenario, action)
            est_s = f"{statistics.median(estimates):>10.2f}" if estimates else f"{'-':>10}"
            true_s = f"{statistics.median(truths):>8.2f}" if truths else f"{'-':>8}"
            err_s = f"{statistics.median(errors):>7.1%}" if errors else f"{'-':>8}"
            print(
                f"{case:<6}{d:>12.2f}{lrn:>11.2f}{(d - lrn) / d:>8.1%}   "
                f"{action:<11}{scen:>11.2f}{est_s}{true_s}{err_s}"
            )
            if case == "slow" and not lrn < d:
                ok = False
    verdict = "PASS" if ok else "FAIL"
    print(f"{verdict}: the learned model's median makespan is lower than the defaults' (slow)")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
