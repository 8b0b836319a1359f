"""Identity of a cell's run and of its scenario (issue 20, "Run identity").

Nothing else ties a command id, an agent, a journal or a store to one cooperation: the manager
numbers its commands 1, 2, ... in every run, so an agent's memory of "command 3 is done" is only
true of the run that sent it. Two names make that explicit:

* the **run id** (:func:`new_run_id`): a random ``uuid4`` hex, made when a run starts and stored
  in its ``start`` event; a resumed cell takes it from the store (:func:`run_of`; a store written
  before run ids existed gets one derived from its ``start``, the same on every resume). Every
  command, suggestion, ``options``, ack, report and store row carries it as ``run``; an agent
  answers from its memory only within one run (``docs/protocol.md``, "Run identity").
* the **scenario fingerprint** (:func:`fingerprint`): a stable hash of what a process reads of
  its scenario — the AND/OR graph's elements, the domain's agents and action schemas, the world's
  objects and facts. An agent announces it when it joins and the manager refuses an agent of
  another scenario; it is stored in ``start`` so ``--resume`` refuses a store of another task
  (:func:`check_resume`).

A missing ``run`` (a message, journal line or store row written before this module) is
*legacy*: accepted as it always was.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import math
import uuid
from collections.abc import Mapping
from enum import Enum
from pathlib import Path
from typing import Any

from flexhrc.errors import FlexhrcError

#: The key of the run id in messages, store rows and journal lines.
RUN = "run"


def new_run_id() -> str:
    """A fresh run id: 32 hex digits, random (uuid4)."""
    return uuid.uuid4().hex


def run_of(start: Mapping[str, Any]) -> str:
    """The run id of a stored ``start`` body: its ``run``, else (a legacy store) one derived
    from the body itself, so every resume of that store continues under the same id."""
    run = start.get(RUN)
    if isinstance(run, str) and run:
        return run
    text = json.dumps(_plain(dict(start)), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def _plain(value: Any) -> Any:
    """``value`` as JSON-able data in an order that does not depend on the process (sets are
    sorted; dataclasses, enums and other objects by their fields or their text)."""
    if isinstance(value, Enum):
        return _plain(value.value)
    if isinstance(value, bool | int | str) or value is None:
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else str(value)
    if isinstance(value, Path):
        return str(value)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {
            f.name: _plain(getattr(value, f.name))
            for f in dataclasses.fields(value)
            if f.compare and not callable(getattr(value, f.name))
        }
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in sorted(value.items(), key=lambda kv: str(kv[0]))}
    if isinstance(value, set | frozenset):
        return sorted((_plain(v) for v in value), key=lambda v: json.dumps(v, sort_keys=True))
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return str(value)


def fingerprint(scenario: Any, *, graph: Any = None, world: Any = None) -> str:
    """The scenario's fingerprint: 16 hex digits of a SHA-256 over its graph (elements, kinds,
    weights), domain (agents, action schemas, processes) and world (objects, facts), as a cell
    and its agents read them. Two processes that load the same scenario (same file, same
    ``--seed``) agree; another task, or the same task with another table, does not. Computed
    once per scenario object; ``graph`` and ``world``: the scenario's fresh online graph and
    knowledge base when the caller has them already (not yet changed by a run)."""
    cached = getattr(scenario, "_flexhrc_fingerprint", None)
    if isinstance(cached, str):
        return cached
    graph = scenario.online_graph() if graph is None else graph
    world = scenario.world() if world is None else world
    shape = {
        "graph": [[n, graph.kind(n), _plain(graph.weight(n))] for n in graph.elements()],
        "domain": _plain(scenario.domain),
        "world": _plain(world.to_dict()),
    }
    utility = getattr(scenario, "utility", None)
    if utility is not None:  # it decides too: a resumed run must score branches alike
        shape["utility"] = utility.to_dict()
    text = json.dumps(shape, sort_keys=True, separators=(",", ":"))
    out = hashlib.sha256(text.encode()).hexdigest()[:16]
    # a scenario with slots keeps no cache: computed again next time
    with contextlib.suppress(AttributeError, TypeError):
        object.__setattr__(scenario, "_flexhrc_fingerprint", out)
    return out


def check_resume(
    start: Mapping[str, Any],
    *,
    where: str,
    scenario: str,
    fingerprint: str,
    seed: int,
    realtime: float,
) -> None:
    """Refuse to resume a store whose ``start`` is of another run than the one asked for: one
    :class:`~flexhrc.errors.FlexhrcError` naming ``where`` (``--store FILE``), what the store
    holds and every difference (scenario, its fingerprint, seed, pace). A legacy ``start``
    without a fingerprint is compared on what it has."""
    stored_fp = start.get("fingerprint")
    diffs = []
    if start.get("scenario") != scenario:
        diffs.append(f"scenario {start.get('scenario')} (this cell: {scenario})")
    elif isinstance(stored_fp, str) and stored_fp != fingerprint:
        diffs.append(
            f"scenario {scenario} with another graph, domain or world (fingerprint "
            f"{stored_fp}, this cell: {fingerprint})"
        )
    if start.get("seed") != seed:
        diffs.append(f"seed {start.get('seed')} (this cell: --seed {seed})")
    stored_rt = start.get("realtime")
    if not isinstance(stored_rt, int | float) or float(stored_rt) != float(realtime):
        diffs.append(f"realtime {_num(stored_rt)} (this cell: --realtime {_num(realtime)})")
    if diffs:
        raise FlexhrcError(
            f"{where}: the store is of another run: {'; '.join(diffs)}. --resume continues "
            "only the run it was given: use its scenario, --seed and --realtime, or a new --store"
        )


def _num(v: Any) -> str:
    return f"{v:g}" if isinstance(v, int | float) and not isinstance(v, bool) else repr(v)


__all__ = ["RUN", "check_resume", "fingerprint", "new_run_id", "run_of"]
