"""``flexhrc scenario validate FILE``, ``flexhrc scenario list``, ``flexhrc scenario new DIR``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from flexhrc.cli.common import add_json_flag, emit
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


def cmd_validate(args: argparse.Namespace) -> int:
    from flexhrc.scenario import check, resolve

    path = resolve(args.file)
    scenario, faults = check(path)
    errors = [f for f in faults if f.severity == "error"]
    if args.json:
        emit(
            args,
            {
                "file": str(path),
                "valid": not errors and scenario is not None,
                "faults": [
                    {
                        "source": f.source,
                        "line": f.line,
                        "severity": f.severity,
                        "message": f.message,
                    }
                    for f in faults
                ],
                "summary": scenario.summary_line() if scenario is not None else None,
            },
        )
        return 2 if errors or scenario is None else 0
    for f in faults:
        print(str(f), file=sys.stderr if f.severity == "error" else sys.stdout)
    if errors or scenario is None:
        return 2
    print(f"{path}: valid: {scenario.summary_line()}")
    return 0


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
    from flexhrc.files import atomic_write_text
    from flexhrc.scenario.starter import STARTER, STARTER_NAME

    folder = Path(args.dir)
    if folder.exists() and not folder.is_dir():
        raise FlexhrcError(f"{folder}: exists and is not a folder (DIR must be a folder)")
    target = folder / STARTER_NAME
    if target.exists() and not args.force:
        raise FlexhrcError(f"{target}: already exists (use --force to overwrite it)")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise FlexhrcError(f"{folder}: cannot create the folder ({exc.strerror})") from None
    atomic_write_text(target, STARTER)
    print(f"wrote {target}")
    print(f"next: flexhrc scenario validate {target} && flexhrc run {target}")
    return 0
