"""Decision policies: who decides what the Task Manager starts at a decision, by name.

The paper's policy (``paper``, the default) is the Task Manager itself: at each decision it takes
the cheapest feasible hyper-arc that no running element conflicts with and gives it the branch
of best utility (paper 000, section V, eq. 21) — one decision at a time, greedy by graph cost.
Another policy is an *advisor* the manager asks first, at the same decision point
(:meth:`TaskManager._start_next`): :meth:`Policy.advise` looks at the manager as it stands (the
online graph, the knowledge base, the running executions and busy agents) and answers an
:class:`Advice` — which feasible hyper-arcs to start now with which agents and grounding, and
which to hold back — or None when it has no answer (the manager then decides as the paper
does). The manager keeps every check of its own (preconditions, conflicts, reservations): an
advice only orders and filters what the paper's loop would do anyway, so the person stays free
to deviate and every deviation is a new decision.

A policy must be deterministic given the manager's state (a stored run is resumed and replayed
by feeding the same inputs again) and must not change the manager: it reads, it advises.

Policies are registered by name (:func:`register_policy`), the built-ins through the same call a
user would: ``paper`` here (None: no advisor), ``lookahead`` by :mod:`flexhrc.planning.policies`
(the package registers it when it is imported; the front ends import it when a run asks for
it). The names a scenario file or a command line may give are
:data:`~flexhrc.events.DECISION_POLICIES`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

from flexhrc.errors import FlexhrcError
from flexhrc.events import DECISION_POLICIES

DEFAULT_POLICY = DECISION_POLICIES[0]


@dataclass(frozen=True)
class Start:
    """Start hyper-arc ``element`` now with ``agents`` (every agent its actions name, in
    order of first use) and, where the advisor knows it, the object ``grounding``."""

    element: str
    agents: tuple[str, ...]
    grounding: Mapping[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class Advice:
    """What a policy says at a decision: ``start`` the hyper-arcs to start now (in that order),
    ``hold`` feasible hyper-arcs that must not start now (they come later, or are the
    alternatives the plan does not take). A feasible hyper-arc in neither is the manager's to
    decide as the paper does."""

    start: tuple[Start, ...] = ()
    hold: frozenset[str] = frozenset()


class Policy(Protocol):
    """An advisor of the Task Manager (see the module docstring)."""

    name: str

    def advise(self, tm: Any, now: float) -> Advice | None:
        """The advice for the decision the :class:`~flexhrc.taskmanager.TaskManager` ``tm`` is
        about to take at cell time ``now`` (the manager imports this module, so the type is not
        named here); None:
        no answer (the paper's decision is taken). Called at every decision: keep it quick,
        deterministic, and never change ``tm``."""
        ...


PolicyFactory = Callable[[], "Policy | None"]
_REGISTRY: dict[str, PolicyFactory] = {}


def register_policy(name: str, factory: PolicyFactory) -> None:
    """Make ``name`` a policy a run may ask for: ``factory()`` builds a fresh advisor for one
    run (None: the paper's decision)."""
    _REGISTRY[name] = factory


def _unknown(option: str, value: object) -> FlexhrcError:
    choices = ", ".join(dict.fromkeys([*DECISION_POLICIES, *_REGISTRY]))
    return FlexhrcError(f"{option} {value!r}: choose one of {choices}")


def make_policy(name: str, option: str = "--policy") -> Policy | None:
    """A fresh advisor for policy ``name`` (None for ``paper``); one error when the name is
    unknown or its package is not loaded."""
    factory = _REGISTRY.get(name)
    if factory is None:
        if name in DECISION_POLICIES:
            raise FlexhrcError(
                f"{option} {name}: the policy is not loaded; import flexhrc.planning first "
                "(it needs the plan extra: pip install 'flexhrc[plan]')"
            )
        raise _unknown(option, name)
    return factory()


def check_policy(value: object, option: str = "--policy") -> str:
    """``value`` if it names a policy (built in, or registered), else one error."""
    if isinstance(value, str) and (value in DECISION_POLICIES or value in _REGISTRY):
        return value
    raise _unknown(option, value)


register_policy(DEFAULT_POLICY, lambda: None)
