"""An operator as its own process that joins a cell over Zenoh and answers from a script:
``python tests/cell/scripted_operator.py SCENARIO ENDPOINT [ELEMENT=ANSWER ...]``.

It is the simulated operator ``flexhrc agent human`` serves (:class:`~flexhrc.cell.HumanAgent`
over :func:`~flexhrc.cell.serve.zenoh_for_cell`, :func:`~flexhrc.cell.serve.serve_until_end`),
with ``replies`` from the command line: ``place_a=decline``, ``place_a=give_back``,
``place_a=cannot:no gloves``, ``*=start`` (every request), ``place_a=ignore``; a request not
named is done. It prints its trace on stderr and the cell's outcome on stdout, and exits 0 when
the cell ended."""

from __future__ import annotations

import sys
from typing import Any


def _replies(script: list[str]) -> Any:
    answers: dict[str, str | tuple[str, str]] = {}
    for item in script:
        element, _, said = item.partition("=")
        kind, _, reason = said.partition(":")
        answers[element] = (kind, reason) if reason else kind

    def replies(element: str, actions: list[str], step: int) -> str | tuple[str, str] | None:
        return answers.get(element, answers.get("*"))

    return replies


def main(argv: list[str]) -> int:
    from flexhrc.cell import HumanAgent
    from flexhrc.cell.components import execution_model
    from flexhrc.cell.serve import serve_until_end, zenoh_for_cell
    from flexhrc.scenario import load_scenario

    path, endpoint, *script = argv
    scenario = load_scenario(path)
    transport = zenoh_for_cell("default", (), (endpoint,))

    def say(line: str) -> None:
        print(f"[human] {line}", file=sys.stderr, flush=True)

    _, outcome = serve_until_end(
        lambda: HumanAgent(
            "human",
            scenario,
            transport,
            execution=execution_model("analytic", scenario),
            trace=say,
            replies=_replies(script),
        ),
        transport,
        say=say,
        ready="ready",
    )
    print(outcome, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
