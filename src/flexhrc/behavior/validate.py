"""Check an executed run against the task's THEN/AND/OR constraints — independently of the network.

The network enforces the constraints by activation spreading; this module checks the *result*
from the run records only (who started when, on which arm, how it ended), so a bug in the
spreading cannot hide itself:

* THEN: no run of a later child starts before the earlier child has completed;
* AND: every child completes;
* OR: exactly one alternative completes and no behaviour of another alternative completes;
* every behaviour completes at most once; runs on one arm never overlap (the mutex);
* the root completes (unless ``require_complete=False``).

:func:`allowed_next` gives the behaviours the constraints allow next, and
:func:`check_nearest_first` checks that, at every step of a one-arm run, the robot took the
nearest allowed object (what the paper's 1/distance potential and OR maximum should produce when
ORs choose among behaviours).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from itertools import pairwise

from flexhrc.behavior.network import Run
from flexhrc.behavior.task import AND, BEHAVIOR, OR, THEN, Task, TaskNode


@dataclass
class _Span:
    complete: bool
    first_start: float | None  # earliest start of any run in the subtree (done or reset)
    end: float | None  # completion time of the subtree
    any_done: bool


def check_run(task: Task, runs: Iterable[Run], require_complete: bool = True) -> list[str]:
    """Return the list of violated constraints (empty when the run is valid)."""
    runs = list(runs)
    problems: list[str] = []
    by_behavior: dict[str, list[Run]] = {}
    for r in runs:
        by_behavior.setdefault(r.behavior, []).append(r)
    for name, rs in by_behavior.items():
        if sum(1 for r in rs if r.outcome == "done") > 1:
            problems.append(f"{name} completed more than once")
    by_arm: dict[str, list[Run]] = {}
    for r in runs:
        by_arm.setdefault(r.arm, []).append(r)
    for arm, rs in by_arm.items():
        rs.sort(key=lambda r: r.start)
        for a, b in pairwise(rs):
            if a.end is None or b.start < a.end:
                problems.append(
                    f"arm {arm}: {b.behavior} started at {b.start} while {a.behavior} ran"
                )

    def span(node: TaskNode) -> _Span:
        if node.kind == BEHAVIOR:
            rs = by_behavior.get(node.name, [])
            done = [r for r in rs if r.outcome == "done"]
            return _Span(
                bool(done),
                min((r.start for r in rs), default=None),
                done[0].end if done else None,
                bool(done),
            )
        spans = [span(c) for c in node.children]
        starts = [s.first_start for s in spans if s.first_start is not None]
        first = min(starts) if starts else None
        any_done = any(s.any_done for s in spans)
        if node.kind == THEN:
            for i, si in enumerate(spans):
                for j in range(i + 1, len(spans)):
                    sj = spans[j]
                    if sj.first_start is None:
                        continue
                    if not si.complete or si.end is None or sj.first_start < si.end:
                        problems.append(
                            f"{node.name}: {node.children[j].name} started at {sj.first_start} "
                            f"before {node.children[i].name} completed"
                        )
            complete = all(s.complete for s in spans)
            end = spans[-1].end if complete else None
            return _Span(complete, first, end, any_done)
        if node.kind == AND:
            complete = all(s.complete for s in spans)
            end = max(s.end for s in spans if s.end is not None) if complete else None
            return _Span(complete, first, end, any_done)
        assert node.kind == OR
        used = [i for i, s in enumerate(spans) if s.any_done]
        if len(used) > 1:
            problems.append(
                f"{node.name}: more than one alternative carried out "
                f"({', '.join(node.children[i].name for i in used)})"
            )
        completed = [s for s in spans if s.complete]
        complete = len(completed) == 1 and len(used) == 1
        return _Span(complete, first, completed[0].end if complete else None, any_done)

    root = span(task.root)
    if require_complete and not root.complete:
        problems.append(f"task not completed: {task.root.name} is not achieved")
    return problems


def allowed_next(task: Task | TaskNode, done: Iterable[str]) -> set[str]:
    """Behaviours the THEN/AND/OR constraints allow to run next, given the completed ones."""
    done_set = set(done)
    root = task.root if isinstance(task, Task) else task

    def complete(node: TaskNode) -> bool:
        if node.kind == BEHAVIOR:
            return node.name in done_set
        if node.kind == OR:
            return any(complete(c) for c in node.children)
        return all(complete(c) for c in node.children)

    def started(node: TaskNode) -> bool:
        return any(n.name in done_set for n in node.walk())

    def enabled(node: TaskNode) -> set[str]:
        if complete(node):
            return set()
        if node.kind == BEHAVIOR:
            return {node.name}
        if node.kind == THEN:
            for c in node.children:
                if not complete(c):
                    return enabled(c)
            return set()
        if node.kind == AND:
            out: set[str] = set()
            for c in node.children:
                out |= enabled(c)
            return out
        for c in node.children:  # OR: committed to a started alternative
            if started(c):
                return enabled(c)
        out = set()
        for c in node.children:
            out |= enabled(c)
        return out

    return enabled(root)


def check_nearest_first(
    task: Task, order: Iterable[str], distance: Mapping[str, float] | Callable[[str], float]
) -> list[str]:
    """For a one-arm run: at each step the behaviour taken must be allowed and no allowed
    behaviour may be strictly nearer. ``distance`` gives each behaviour's arm–object distance at
    the moment it was chosen (static layouts: from the arm's rest pose)."""
    dist = distance if callable(distance) else distance.__getitem__
    problems: list[str] = []
    done: list[str] = []
    for step, name in enumerate(order, start=1):
        allowed = allowed_next(task, done)
        if name not in allowed:
            problems.append(f"step {step}: {name} was not allowed (allowed: {sorted(allowed)})")
        else:
            nearest = min(allowed, key=lambda b: (dist(b), b))
            if dist(nearest) < dist(name) - 1e-9:
                problems.append(
                    f"step {step}: took {name} ({dist(name):.3f} m) but {nearest} was nearer "
                    f"({dist(nearest):.3f} m)"
                )
        done.append(name)
    return problems
