"""``flexhrc learn STORE... -o operators.yaml``: an operator model from cell event stores."""

from __future__ import annotations

import argparse
from typing import Any

from flexhrc.cli.common import add_json_flag, emit


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg, unused-ignore]
    p = sub.add_parser(
        "learn",
        help="learn an operator model (per person and action: durations, declines) from stores",
        description="Read cell event stores (flexhrc cell --store, panel --store) and write an "
        "operator model: per person and action, the durations they took (median, spread) and "
        "the share of suggestions they declined or could not do (docs/operators.md). "
        "`flexhrc run|cell --operators FILE` times each person's steps by it.",
    )
    p.add_argument("stores", nargs="+", metavar="STORE", help="event stores (.db) to learn from")
    p.add_argument(
        "-o",
        "--output",
        required=True,
        metavar="FILE",
        help="the operator model to write (.yaml or .yml), atomically",
    )
    add_json_flag(p)
    p.set_defaults(func=cmd_learn)


def cmd_learn(args: argparse.Namespace) -> int:
    from flexhrc.app.learn import learn_model
    from flexhrc.files import check_output
    from flexhrc.taskmanager.operator_model import write_model

    # checked before any store is read: a run of minutes never ends on "cannot write"
    check_output(args.output, option="-o", suffixes=(".yaml", ".yml"), inputs=args.stores)
    model = learn_model(args.stores)
    write_model(model, args.output)
    data: dict[str, Any] = {"output": str(args.output), **model.to_dict()}
    emit(args, data, lambda: text(model, args.output))
    return 0


def text(model: Any, output: str) -> str:
    """One line per person and action: samples, median and spread; then the answers."""
    lines = []
    for name, person in sorted(model.persons.items()):
        lines.append(
            f"{name}: {person.suggestions} suggestions, declined {person.declined} "
            f"({person.decline_rate:.0%}), cannot {person.cannot} ({person.cannot_rate:.0%})"
        )
        for action, est in sorted(person.actions.items()):
            lines.append(
                f"  {action:<16} n={est.n:<3} median {est.median_s:.2f} s  "
                f"spread {est.spread_s:.2f} s"
            )
    if not model.persons:
        lines.append("no person acted in these stores")
    lines.append(f"operator model written to {output}")
    return "\n".join(lines)
