"""``flexhrc scenario validate FILE``, ``flexhrc scenario list``, ``flexhrc scenario new DIR``,
``flexhrc scenario generate --actions N --agents M --width W --seed S [-o FILE]``."""

from __future__ import annotations

import argparse
import sys

from flexhrc.cli.common import add_json_flag, emit, int_range
from flexhrc.errors import FlexhrcError


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg, unused-ignore]
    p = sub.add_parser(
        "scenario",
        help="check, list and start scenario files (your own cooperation task)",
        description="Scenario files (flexhrc: 1) describe a whole cooperation: graph, domain, "
        "world and operators (docs/scenarios.md). Run one with: flexhrc run FILE|NAME.",
    )
    ssub = p.add_subparsers(dest="scenario_command", metavar="COMMAND", required=True)
    v = ssub.add_parser(
        "validate",
        help="check a scenario file: one line per fault (FILE:LINE: message)",
        description="Check a scenario file and the files it names. Valid: exit 0 and a "
        "summary line; otherwise every fault as FILE:LINE: message and exit 2. Warnings (a "
        "predicate nothing can make true) are printed but do not fail.",
    )
    v.add_argument("file", metavar="FILE|NAME", help="a scenario file or a shipped name")
    add_json_flag(v)
    v.set_defaults(func=cmd_validate)
    ls = ssub.add_parser("list", help="the shipped scenarios, one line each")
    add_json_flag(ls)
    ls.set_defaults(func=cmd_list)
    n = ssub.add_parser(
        "new",
        help="write a commented starter scenario into DIR",
        description="Write DIR/scenario.yaml: a small commented scenario that validates and "
        "runs, to change into your own task.",
    )
    n.add_argument("dir", metavar="DIR", help="folder to create (or an empty one)")
    n.add_argument("--force", action="store_true", help="overwrite DIR/scenario.yaml")
    n.set_defaults(func=cmd_new)
    g = ssub.add_parser(
        "generate",
        help="write a random task: N steps, M agents (arms and persons), width W",
        description="Write a random, valid scenario (flexhrc: 1): an assembly of N steps with "
        "alternatives (an arm's or a person's), joint actions of two arms, arm-only and "
        "person-only steps, and parts some arms cannot reach. The same arguments give the same "
        "file. Without -o the YAML goes to stdout (docs/scenarios.md#generated-tasks).",
    )
    whole = int_range()  # a whole number; the ranges are the library's (one message each)
    g.add_argument(
        "--actions",
        type=whole,
        required=True,
        metavar="N",
        help="steps of the task (every cooperation path has N actions)",
    )
    g.add_argument(
        "--agents",
        type=whole,
        required=True,
        metavar="M",
        help="agents: robot arms and persons (at least 2)",
    )
    g.add_argument(
        "--width",
        type=whole,
        required=True,
        metavar="W",
        help="the most steps that can be done at once (1..N)",
    )
    g.add_argument("--seed", type=whole, default=0, metavar="S", help="random seed (default 0)")
    g.add_argument(
        "--persons",
        type=whole,
        default=None,
        metavar="P",
        help="how many of the agents are persons (default: a quarter, at least 1)",
    )
    g.add_argument("-o", "--output", metavar="FILE", help="the scenario file to write (.yaml)")
    g.add_argument("--force", action="store_true", help="overwrite FILE")
    g.set_defaults(func=cmd_generate)


def cmd_validate(args: argparse.Namespace) -> int:
    from flexhrc.scenario import Fault, validation

    report = validation(args.file)
    if args.json:
        emit(args, report)
    else:
        for f in (Fault(**fault) for fault in report["faults"]):
            print(str(f), file=sys.stderr if f.severity == "error" else sys.stdout)
        if report["valid"]:
            print(f"{report['file']}: valid: {report['summary']}")
    return 0 if report["valid"] else 2


def cmd_list(args: argparse.Namespace) -> int:
    from flexhrc.scenario import describe_shipped

    items = describe_shipped()
    emit(
        args,
        [{"name": n, "description": d} for n, d in items],
        "\n".join(f"{n:<16} {d}" for n, d in items),
    )
    return 0


def cmd_new(args: argparse.Namespace) -> int:
    from flexhrc.scenario.starter import write_starter

    target = write_starter(args.dir, force=args.force)
    return _wrote(target)


def cmd_generate(args: argparse.Namespace) -> int:
    from flexhrc.scenario.generate import generate, write_generated

    spec = dict(
        actions=args.actions,
        agents=args.agents,
        width=args.width,
        seed=args.seed,
        persons=args.persons,
    )
    if args.output is None:
        if args.force:
            raise FlexhrcError("--force goes with -o FILE (without -o the YAML goes to stdout)")
        sys.stdout.write(generate(**spec))
        return 0
    target = write_generated(args.output, force=args.force, **spec)
    return _wrote(target)


def _wrote(target: object) -> int:
    """Say where the new scenario is and what to do with it next."""
    print(f"wrote {target}")
    print(f"next: flexhrc scenario validate {target} && flexhrc run {target}")
    return 0
