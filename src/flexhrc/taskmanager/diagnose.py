"""Why a cooperation cannot go on: what waits on what, read from a Task Manager's state.

A loop that finds nothing running and nothing to come while the root is not met ends the run
("deadlock"). :func:`stall_reason` says why, from what the manager knows — it reads, never
changes, and is sans-IO like the manager:

* a **node reached but not met**: one of its hyper-arcs is solved, yet ``S(n)`` does not hold
  under the grounding carried from it — the literals that are false;
* a **feasible hyper-arc not started**: its decision tree (built again, as the manager builds
  it) has no branch — every grounding fails a precondition (the branch that got furthest, with
  the literals that fail), no grounding fits the children's formulas, an agent it needs is busy
  or has left the cell, or every grounding failed before;
* an **execution waiting**: a step suggested to an operator who has not done it, a command
  with no acknowledgement;
* **elements marked infeasible** on the way, and why (again from their decision trees).
"""

from __future__ import annotations

from collections.abc import Iterable

from flexhrc.logic import Literal, apply_substitution
from flexhrc.taskmanager.decision import Branch, DecisionTree, holds
from flexhrc.taskmanager.manager import TaskManager

#: the sentence the loops have always printed; the explanation follows it after ": "
DEADLOCK = "deadlock: no agent has anything to do and the task is not solved"


def stall_reason(tm: TaskManager) -> str:
    """``DEADLOCK: what waits on what`` for a manager that can go no further — and, when the
    knowledge base is inconsistent (the manager waits for perception to settle it), why."""
    parts = [*_waiting_nodes(tm), *_waiting_hyperarcs(tm), *_infeasible(tm), *_agents(tm)]
    reason = f"{DEADLOCK}: {'; '.join(parts)}" if parts else DEADLOCK
    if not tm.kb.consistent:
        why = "; ".join(i.reason for i in tm.kb.inconsistencies)
        reason += f" (the knowledge base is inconsistent: {why})"
    return reason


def _feasible(tm: TaskManager) -> list[str]:
    g = tm.graph
    return [n for n in g.elements() if g.is_feasible(n)]


def _incoming(tm: TaskManager, node: str) -> list[str]:
    """The hyper-arcs whose parent is ``node`` (qualified names)."""
    g = tm.graph
    d = g.definition_of(node)
    local, prefix = g.local_name(node), g.graph_of(node)
    return [
        f"{prefix}/{h.name}" if prefix else h.name
        for h in d.hyperarcs.values()
        if h.parent == local
    ]


def _formula(tm: TaskManager, node: str) -> tuple[Literal, ...]:
    n = tm.graph.definition_of(node).nodes[tm.graph.local_name(node)]
    formula = n.formula or ()
    binding = tm.bindings.get(node)
    return tuple(apply_substitution(lit, binding) for lit in formula) if binding else formula


def _false(formula: Iterable[Literal], facts: frozenset[tuple[str, ...]]) -> list[Literal]:
    """The literals of a formula that fail: ground ones one by one; the rest together when no
    grounding satisfies them."""
    formula = tuple(formula)
    bad = [x for x in formula if x.is_ground and (x.key() in facts) == x.negated]
    free = [x for x in formula if not x.is_ground]
    if free and not holds(free, facts):
        bad += free
    return bad


def _conj(lits: Iterable[Literal]) -> str:
    return " & ".join(str(x) for x in lits)


def _waiting_nodes(tm: TaskManager) -> list[str]:
    out = []
    facts = tm.kb.facts
    for node in _feasible(tm):
        if tm.graph.kind(node) != "node":
            continue
        solved = [h for h in _incoming(tm, node) if tm.graph.is_solved(h)]
        bad = _false(_formula(tm, node), facts)
        if bad:
            via = f" (its hyper-arc {', '.join(solved)} is solved)" if solved else ""
            out.append(f"node {node} waits for {_conj(bad)}{via}")
        elif node in tm.processes:
            out.append(f"node {node} waits for its processes to end")
    return out


def _tree(tm: TaskManager, name: str, *, free: bool) -> DecisionTree:
    """The decision tree the manager would build now (``free``: as if every agent were free
    and nothing reserved, the question being whether anything fits at all)."""
    available = None
    reserved: set[str] = set()
    if not free:
        busy_humans = {a for ex in tm.executions.values() if ex.owner == "human" for a in ex.agents}
        available = [
            a.name
            for a in tm.domain.agents.values()
            if a.name not in tm.unavailable and a.name not in tm.busy and a.name not in busy_humans
        ]
        reserved = tm.reserved_objects()
    return DecisionTree.build(
        name,
        tm.actions_of(name),
        tm.constraints_of(name),
        tm.domain,
        tm.kb,
        exclude=tm.failed.get(name, ()),
        available_agents=available,
        reserved=reserved,
        binding=tm.binding_of(name),
    )


def _furthest(pruned: list[Branch]) -> Branch:
    """The pruned branch that got furthest (its failing step latest), first on ties."""

    def reached(b: Branch) -> int:
        for i, step in enumerate(b.steps):
            if b.pruned and b.pruned.startswith(f"pre({step})"):
                return i
        return -1

    return max(pruned, key=reached)


def _why_not(tm: TaskManager, name: str) -> str:
    tree = _tree(tm, name, free=False)
    if tree.branches:
        return f"{len(tree.branches)} branch(es) could start"
    if tree.pruned:
        return f"every grounding fails a precondition: {_furthest(tree.pruned).pruned}"
    anyone = _tree(tm, name, free=True)
    if anyone.branches or anyone.pruned:
        wanted = sorted({a for b in [*anyone.branches, *anyone.pruned] for a in b.agents})
        held = sorted(set(wanted) & (set(tm.busy) | tm.unavailable))
        if held:
            return f"it needs {', '.join(held)} ({_held(tm, held)})"
        return "the objects it needs are in use by another execution"
    if tm.failed.get(name):
        return f"every grounding failed before ({len(tm.failed[name])} tried)"
    constraints = tm.constraints_of(name)
    bad = _false(constraints, tm.kb.facts) if constraints else []
    if bad:
        return f"no grounding fits its children's formulas: {_conj(bad)} is false"
    return "no grounding or agent fits its actions"


def _held(tm: TaskManager, agents: list[str]) -> str:
    out = []
    for a in agents:
        if a in tm.unavailable:
            out.append(f"{a} has left the cell")
        elif a in tm.busy:
            cmd = tm.busy[a]
            out.append(f"{a} is busy with {cmd.action}")
    return ", ".join(out)


def _waiting_hyperarcs(tm: TaskManager) -> list[str]:
    out = []
    for name in tm.feasible_hyperarcs():
        ex = tm.executions.get(name)
        if ex is not None:
            step = ex.branch.steps[ex.next_index] if ex.next_index < len(ex.branch.steps) else None
            who = ", ".join(ex.agents)
            if ex.owner == "human":
                out.append(f"hyper-arc {name} waits for {who} to do {step} (suggested)")
            elif ex.command is not None:
                out.append(f"hyper-arc {name} waits for {who} to finish {ex.command.action}")
            else:
                out.append(f"hyper-arc {name} waits for its next command ({step})")
            continue
        if not tm.actions_of(name):
            continue
        out.append(
            f"hyper-arc {name} (into {tm.parent_of(name)}) cannot start: {_why_not(tm, name)}"
        )
    return out


def _infeasible(tm: TaskManager) -> list[str]:
    """Elements marked infeasible, with the reason the manager gave when it marked them (the
    world has changed since: a decision tree built now could tell another story)."""
    out = []
    marked = list(tm.infeasible)
    marked += [ev.element for ev in tm.graph.events if ev.type == "infeasible"]
    for name in dict.fromkeys(marked):
        what = "hyper-arc" if tm.graph.kind(name) == "hyperarc" else "node"
        into = f" (into {tm.parent_of(name)})" if what == "hyper-arc" else ""
        why = tm.infeasible.get(name)
        out.append(f"{what} {name}{into} is infeasible" + (f": {why}" if why else ""))
    return out


def _agents(tm: TaskManager) -> list[str]:
    out = []
    if tm.unavailable:
        out.append(f"agents that left the cell: {', '.join(sorted(tm.unavailable))}")
    # an inconsistent knowledge base (perception): the perceiving loop says so itself
    return out


__all__ = ["DEADLOCK", "stall_reason"]
