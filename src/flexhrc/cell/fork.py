"""What-if from the store (issue 22, item 5): ``flexhrc replay STORE --fork-at K``.

A cell's event store holds every input of the Task Manager, and the manager is deterministic
given its inputs (``docs/cell.md``, event sourcing), so the cooperation *as it was* after event
``K`` is rebuilt exactly as a crashed cell is: :func:`fork_store` copies the first ``K`` events
into a new store and resumes it — the one loop, :class:`~flexhrc.cell.supervisor.Cell` with
``resume=True``, through :func:`~flexhrc.cell.serve.serve_cell` with simulated agents in this
process — and from there the cooperation goes on with the new choices:

* ``human`` — the operators' profile from event ``K`` on (stored as the input ``operator``,
  :meth:`~flexhrc.cell.supervisor.Cell.set_operator_profile`, so the fork itself resumes and
  replays); None keeps the stored one (the profile each operator's process had in the run);
* ``operators`` — the operator model file (``flexhrc learn``) the manager times the people's
  steps by, for the whole fork (the replayed prefix too); None: the model the stored ``start``
  holds (``operator_model``, a run made with ``--operators``), so such a run forks faithfully
  without its file;
* ``utility`` — the branch utility from event ``K`` on (a ``utility:`` block, stored as the
  input ``utility``, :meth:`~flexhrc.cell.supervisor.Cell.set_utility`); the prefix replays
  under the scenario's own;
* ``on_failure`` — the failure policy; the prefix replays under the policy it was stored with,
  so a fork that changes it is refused when a robot action failed within the first ``K`` events.

The fork is a run of its own: its rows carry a new run id (:mod:`flexhrc.cell.identity`), its
``start`` names the run and event it was forked from (``fork``: ``run``, ``at``, ``store``) and
it goes on as fast as the simulated agents answer (``realtime`` 0). With the stored choices the
fork reproduces the stored run to its end, event for event (the closing ``summary`` aside, which
holds wall-clock figures). :class:`ForkReport` holds both runs' summaries; :func:`compare_text`
prints them side by side (makespan, ``by_agent``, the person's share). The command,
its plot included, is :func:`flexhrc.app.what_if`.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from flexhrc.cell import identity
from flexhrc.cell.components import ScenarioLike
from flexhrc.cell.store import EventStore, StoredEvent, check_events, read_store, summarise_store
from flexhrc.errors import FlexhrcError
from flexhrc.files import check_output

#: The suffixes a forked store may have (as ``--store``).
STORE_SUFFIXES = (".db", ".sqlite", ".sqlite3")


@dataclass
class ForkReport:
    """The stored run and its what-if: each one's summary (the keys of ``flexhrc replay
    --json``, both read back from their stores alike) and events in log form; ``at``: the last
    event the fork shares; ``store``: where the fork is kept; ``profiles``: the operators'
    profiles of each run (operator -> profile at the end)."""

    source: Path
    store: Path
    at: int
    original: dict[str, Any]
    fork: dict[str, Any]
    original_events: list[dict[str, Any]] = field(default_factory=list)
    fork_events: list[dict[str, Any]] = field(default_factory=list)
    profiles: dict[str, dict[str, str]] = field(default_factory=dict)
    humans: list[str] = field(default_factory=list)
    #: the time of event ``at`` on the cell's clock (where the runs part)
    at_t: float = 0.0

    def to_json(self) -> dict[str, Any]:
        """``flexhrc replay STORE --fork-at K --json``."""
        return {
            "fork_at": self.at,
            "fork_t": self.at_t,
            "original": {"store": str(self.source), **_figures(self.original, self.humans)},
            "fork": {"store": str(self.store), **_figures(self.fork, self.humans)},
            "profiles": self.profiles,
            "summaries": {"original": self.original, "fork": self.fork},
        }


def default_output(source: str | Path, at: int) -> Path:
    """Where a fork goes without ``-o``: ``STORE-forkK.db`` beside the stored one."""
    p = Path(source)
    return p.with_name(f"{p.stem}-fork{at}{p.suffix or '.db'}")


def check_fork_output(
    out: str | Path, source: str | Path, *, force: bool = False, option: str = "-o"
) -> Path:
    """Check the fork's store path before any work: writable, a store suffix, never the stored
    run itself, and not an existing file unless ``force`` (then it is replaced once the fork
    is made). A bad path is one :class:`~flexhrc.files.OutputPathError` naming ``option``."""
    from flexhrc.files import OutputPathError

    p = check_output(out, option=option, suffixes=STORE_SUFFIXES, inputs=[source])
    if p.exists() and not force:
        raise OutputPathError(
            f"{option} {p}: already exists; choose a new file, or add --force to replace it"
        )
    return p


def check_fork_at(events: list[StoredEvent], at: int, source: str | Path) -> None:
    """``K`` must name an event of the stored run before its end: from 1 (the ``start``) to
    the last event before the ``outcome`` (or the last one of a run cut short)."""
    end = next((ev.seq for ev in events if ev.kind == "outcome"), None)
    last = end - 1 if end is not None else len(events)
    if not 1 <= at <= last:
        why = (
            f"the run ended at event {end} (outcome)"
            if end is not None
            else f"the store holds {len(events)} events"
        )
        raise FlexhrcError(
            f"--fork-at {at}: out of range for {source}: give an event from 1 to {last} ({why})"
        )


def stored_profiles(events: list[StoredEvent]) -> dict[str, str]:
    """Each operator's profile after ``events``: the ``start``'s ``operators``, then every
    ``operator`` input (an operator not named is ``passive``)."""
    start = events[0].body
    out = {str(h): "passive" for h in start.get("humans") or []}
    out.update({str(k): str(v) for k, v in (start.get("operators") or {}).items()})
    for ev in events:
        if ev.kind == "operator":
            out[str(ev.body["agent"])] = str(ev.body["profile"])
    return out


def fork_store(
    source: str | Path,
    at: int,
    out: str | Path | None = None,
    *,
    scenario: ScenarioLike | Callable[[str, int], ScenarioLike],
    human: str | None = None,
    on_failure: str | None = None,
    operators: str | Path | None = None,
    utility: Mapping[str, Any] | None = None,
    force: bool = False,
    progress: Callable[[str], None] | None = None,
) -> ForkReport:
    """Fork the run stored in ``source`` after its event ``at`` into the store ``out`` (default
    :func:`default_output`) and run it to its end with simulated agents (module docstring).

    ``scenario``: the stored run's scenario, loaded, or a loader called with the name and seed
    the stored ``start`` holds (:func:`flexhrc.app.what_if` loads shipped scenarios and files
    so). Every check — the paths, ``at``, the options, the scenario against the stored
    fingerprint — comes before any file is written; each is one
    :class:`~flexhrc.errors.FlexhrcError`."""
    from flexhrc.cell.serve import CellConfig, serve_cell
    from flexhrc.cell.supervisor import failure_policy
    from flexhrc.taskmanager.operator import PROFILES

    source = Path(source)
    target = Path(out) if out is not None else default_output(source, at)
    check_fork_output(target, source, force=force)
    if human is not None and human not in PROFILES:
        raise FlexhrcError(f"--human {human!r}: choose one of {', '.join(PROFILES)}")
    if on_failure is not None:
        failure_policy(None, on_failure)
    events = read_store(source)
    if not events:
        raise FlexhrcError(f"{source}: empty store: nothing to fork")
    check_events(events, source)
    check_fork_at(events, at, source)
    prefix = events[:at]
    start = dict(prefix[0].body)
    # the stored choice is the profile each operator's process had in the whole run: one that
    # acts on its own may announce itself only after event K (it does so again in the fork)
    was = stored_profiles(events)
    if human is None and len(set(was.values())) > 1:
        said = ", ".join(f"{h}: {p}" for h, p in sorted(was.items()))
        raise FlexhrcError(
            f"{source}: the operators had different profiles ({said}); give --human PROFILE"
        )
    profile = human if human is not None else next(iter(was.values()), "passive")
    if on_failure is not None and on_failure != start.get("on_failure", "retry"):
        failed = next(
            (ev for ev in prefix if ev.kind == "ack" and ev.body.get("status") != "done"), None
        )
        if failed is not None:
            raise FlexhrcError(
                f"--on-failure {on_failure}: a robot action failed at event {failed.seq}, "
                f"before event {at}, under the stored policy "
                f"{start.get('on_failure', 'retry')!r}; fork before it to change the policy"
            )
    seed = start.get("seed", 0)
    if not isinstance(seed, int) or isinstance(seed, bool):
        raise FlexhrcError(f"{source}: the stored start has no whole-number seed ({seed!r})")
    if callable(scenario):
        name = start.get("scenario")
        if not isinstance(name, str) or not name:
            raise FlexhrcError(f"{source}: the stored start names no scenario; give --scenario")
        scenario = scenario(name, seed)
    stored_fp = start.get("fingerprint")
    if isinstance(stored_fp, str) and stored_fp != identity.fingerprint(scenario):
        raise FlexhrcError(
            f"{source}: the stored run is of another scenario {start.get('scenario')!r} than "
            f"the one loaded (another graph, domain or world): give it with --scenario FILE"
        )
    if utility is not None:  # its names against the scenario, before any file is written
        from flexhrc.taskmanager.utility import parse_utility

        problems = parse_utility(utility, scenario.domain)[1]
        if problems:
            raise FlexhrcError(f"--utility: {problems[0][0]}")
    old_run = identity.run_of(prefix[0].body)
    run = identity.new_run_id()
    start.update(
        {
            identity.RUN: run,
            "realtime": 0.0,  # the simulated agents answer at once
            "fork": {"run": old_run, "at": at, "store": str(source)},
        }
    )
    if on_failure is not None:
        start["on_failure"] = on_failure
    if operators is not None:  # the fork's own start holds the model it runs by (its resume)
        from flexhrc.taskmanager.operator_model import read_model

        start["operator_model"] = read_model(operators).to_dict()
    simulator = str(start.get("simulator") or "auto")
    if simulator not in ("analytic", "kinematic"):
        simulator = "auto"
    if force:
        _remove(target)
    with EventStore(target, option="-o") as store:
        store.append("start", start, prefix[0].t)
        for ev in prefix[1:]:
            store.append(ev.kind, {**ev.body, identity.RUN: run}, ev.t)
    humans = [str(h) for h in start.get("humans") or []]

    def new_choices(cell: Any) -> Any:
        _check_replayed(cell, prefix, source)
        if human is not None:  # before the loop moves on: the fork's first input from K
            for name in humans:
                cell.set_operator_profile(name, profile)
        if utility is not None:
            cell.set_utility(utility, where="--utility")
        return _Nothing()

    try:
        serve_cell(
            scenario,
            CellConfig(
                seed=seed,
                store=target,
                resume=True,
                simulator=simulator,
                on_failure=on_failure,
                human=profile,
                operators=operators,
            ),
            progress=progress,
            attach=[new_choices],
        )
    except FlexhrcError:
        _remove(target)  # a fork that could not be rebuilt leaves no store behind
        raise
    original, original_events = summarise_store(source)
    forked, fork_events = summarise_store(target)
    return ForkReport(
        source,
        target,
        at,
        original,
        forked,
        original_events,
        fork_events,
        {"original": stored_profiles(events), "fork": stored_profiles(read_store(target))},
        humans,
        prefix[-1].t,
    )


def _remove(path: Path) -> None:
    """A store and its ``-wal`` and ``-shm`` files, if there."""
    for name in (str(path), f"{path}-wal", f"{path}-shm"):
        with contextlib.suppress(FileNotFoundError):
            os.unlink(name)


def _check_replayed(cell: Any, prefix: list[StoredEvent], source: Path) -> None:
    """The replayed manager issued every stored command of the first ``K`` events as stored
    (action, agents, hyper-arc): else the run was made under something the store does not
    hold (an operator model, another scenario version) and the fork would not continue it."""
    for ev in prefix:
        if ev.kind != "command":
            continue
        cmd = cell.commands.get(int(ev.body["id"]))
        made = cmd.to_dict() if cmd is not None else {}
        keys = ("action", "agents", "element")
        if cmd is None or any(made.get(k) != ev.body.get(k) for k in keys):
            raise FlexhrcError(
                f"{source}: event {ev.seq} (command {ev.body['id']}: {ev.body.get('action')}) "
                f"does not replay as stored (the manager now issues "
                f"{made.get('action', 'nothing')}): the run was made under something the store "
                "does not hold — an operator model (give it with --operators FILE) or another "
                "version of its scenario"
            )


def profiles_text(profiles: dict[str, str]) -> str:
    """``human: takeover, ...`` (operator: profile), for the comparison and the plot."""
    return ", ".join(f"{h}: {p}" for h, p in sorted(profiles.items())) or "no operator"


class _Nothing:
    """The component :func:`fork_store` attaches only to make its choices: nothing to poll."""

    def poll(self) -> None:
        pass

    def close(self) -> None:
        pass


def person_share(data: dict[str, Any], humans: list[str]) -> float:
    """The person's share of the cooperation: the ``humans``' hyper-arcs over all solved ones
    (``by_agent``, the summary's own count; 0 when none was solved)."""
    by = data.get("by_agent", {})
    total = sum(by.values())
    mine = sum(n for a, n in by.items() if a in humans)
    return mine / total if total else 0.0


def _figures(data: dict[str, Any], humans: list[str]) -> dict[str, Any]:
    return {
        "outcome": data["outcome"],
        "makespan_s": data["timing"]["total_s"],
        "by_agent": dict(data["by_agent"]),
        "person_share": round(person_share(data, humans), 4),
        "human_actions": data["human_actions"],
        "robot_actions": data["robot_actions"],
    }


def compare_text(report: ForkReport) -> str:
    """Both runs side by side: outcome, makespan, hyper-arcs by agent, the person's share."""
    a, b = _figures(report.original, report.humans), _figures(report.fork, report.humans)
    pa, pb = report.profiles.get("original", {}), report.profiles.get("fork", {})
    rows = [
        ("", "stored run", f"what-if (from event {report.at})"),
        ("store", str(report.source), str(report.store)),
        ("operators", profiles_text(pa), profiles_text(pb)),
        ("outcome", a["outcome"], b["outcome"]),
        ("makespan", f"{a['makespan_s']:.2f} s", f"{b['makespan_s']:.2f} s"),
    ]
    for agent in sorted({*a["by_agent"], *b["by_agent"]}):
        rows.append(
            (f"by {agent}", str(a["by_agent"].get(agent, 0)), str(b["by_agent"].get(agent, 0)))
        )
    rows += [
        ("person's share", f"{a['person_share']:.0%}", f"{b['person_share']:.0%}"),
        ("robot actions", str(a["robot_actions"]), str(b["robot_actions"])),
        ("human actions", str(a["human_actions"]), str(b["human_actions"])),
    ]
    w0 = max(len(r[0]) for r in rows)
    w1 = max(len(r[1]) for r in rows)
    return "\n".join(f"{r[0]:<{w0}}  {r[1]:<{w1}}  {r[2]}".rstrip() for r in rows)
