"""The knowledge base: typed objects with poses and sizes, and ground facts (paper 000, V-VI).

Objects (``leg1`` of type ``leg`` at a pose, with a size) and facts (``("on_table", "leg1")``)
are what the Task Manager grounds action parameters against. Queries are closed-world: a fact
that is not stored is false. Every object contributes the unary fact ``(type, id)``, so
``leg(?l) & on_table(?l)`` finds the legs lying on the table.

Types may have supertypes (``supertypes={"leg_long": "leg"}``): an object of type ``leg_long``
also makes ``leg(id)`` true, so a task written for legs accepts the long legs scene perception
reports.

Percepts and action effects update the base. A percept that contradicts what is stored — another
type for a known id, a size off by more than the tolerance, an object that is fixed in place but
seen elsewhere — is *not* applied: it is kept as an :class:`Inconsistency` and the base is
:attr:`~KnowledgeBase.consistent` no more, so the Task Manager waits (paper VI-E) until
:meth:`~KnowledgeBase.resolve` accepts or rejects it. Nothing is silently overwritten.

Anchoring (paper VI-D; :mod:`flexhrc.perception.scene.anchoring` does the matching): a symbol may
be known by name and type before anything is known of where it is (:meth:`~KnowledgeBase.
add_symbol`); :meth:`~KnowledgeBase.observe` applies a percept matched to a symbol, and a percept
that agrees with the base clears that symbol's pending inconsistencies — a later compatible
percept ends the inconsistent state. :meth:`~KnowledgeBase.contradict` records an inconsistency
found by a caller's own check (e.g. a reported belief a look does not confirm).

Both ways a percept reaches the base — :meth:`~KnowledgeBase.update_object` (the perception
modules' ``ObjectSink``, and the live cell's ``percept`` messages) and
:meth:`~KnowledgeBase.observe` (anchoring) — follow the two assumptions of paper 000, VI-E
(Discussion): *closed world* and *continuity*, "any change in the robot workspace is the
consequence of actions performed by the human operator or the robot". So:

* a percept compatible with what is stored clears the object's pending inconsistencies ("the
  knowledge base enters an inconsistent state, and waits for new, compatible, information");
* continuity: a percept that carries its time ``t`` (seconds, the percept's own clock — never the
  wall clock, so a replay decides the same) is checked against the object's last percept: a
  non-fixed object seen farther from where it was last perceived than any agent could carry it
  in the meantime — :attr:`~KnowledgeBase.max_speed_m_s` times the time elapsed, plus
  :attr:`~KnowledgeBase.continuity_margin_m` for what perception itself is off by — and not
  where the belief has it (an action's effect, :meth:`~KnowledgeBase.move`, explains a change)
  is an inconsistency. A percept without a time is checked for everything else.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

from flexhrc.errors import FlexhrcError, UnknownNameError
from flexhrc.logic import (
    Conjunction,
    Literal,
    Substitution,
    apply_substitution,
    index_facts,
    satisfy,
)

Vec3 = tuple[float, float, float]
_INF = math.inf

#: The default continuity bound (m/s): no agent of the cell carries an object faster. A person's
#: hand moving a part across a workbench stays well under it (reaching movements peak around
#: 1 m/s); a leg seen metres away a moment later is a perception error, not a motion.
MAX_SPEED_M_S = 1.5
#: What a percept's position may be off by without any motion (m): a part partly hidden by an
#: arm is seen with its centre shifted (the anchoring gate has the same size).
CONTINUITY_MARGIN_M = 0.10


@dataclass
class ObjectRecord:
    """One object of the workspace."""

    id: str
    type: str
    position: Vec3
    size: dict[str, float] = field(default_factory=dict)
    attrs: dict[str, Any] = field(default_factory=dict)
    fixed: bool = False  # e.g. a leg screwed to the tabletop: it cannot be seen elsewhere
    anchored: bool = True  # False: known by name and type, where it is not perceived yet

    def to_dict(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "type": self.type,
            "position": list(self.position),
            "size": dict(self.size),
            "attrs": dict(self.attrs),
            "fixed": self.fixed,
            "anchored": self.anchored,
        }


@dataclass
class Inconsistency:
    """A percept that contradicts the knowledge base, waiting for a decision."""

    object_id: str
    reason: str
    percept: dict[str, Any]


class KnowledgeBase:
    """Typed objects and ground facts with closed-world queries and a consistency check."""

    def __init__(
        self,
        *,
        size_tolerance: float = 0.05,
        position_tolerance: float = 0.02,
        supertypes: Mapping[str, str] | None = None,
        max_speed_m_s: float = MAX_SPEED_M_S,
        continuity_margin_m: float = CONTINUITY_MARGIN_M,
    ):
        """``max_speed_m_s`` and ``continuity_margin_m`` bound how far an object may move
        between two timed percepts (see the module; ``math.inf`` turns the check off)."""
        for name, v in (
            ("max_speed_m_s", max_speed_m_s),
            ("continuity_margin_m", continuity_margin_m),
        ):
            if not (isinstance(v, int | float) and not math.isnan(v) and v > 0):
                raise FlexhrcError(f"{name} must be a number > 0, got {v!r}")
        self.objects: dict[str, ObjectRecord] = {}
        self.supertypes: dict[str, str] = dict(supertypes or {})
        self._facts: set[tuple[str, ...]] = set()
        # views of _facts made on demand and kept, with the generation of the facts they were
        # made from, until the facts change (_facts_changed): every decision reads the facts
        # many times between two changes
        self._facts_gen = 0
        self._frozen: tuple[int, frozenset[tuple[str, ...]]] | None = None
        self._index: tuple[int, dict[str, list[tuple[str, ...]]]] | None = None
        self.size_tolerance = size_tolerance
        self.position_tolerance = position_tolerance
        self.inconsistencies: list[Inconsistency] = []
        self.max_speed_m_s = float(max_speed_m_s)
        self.continuity_margin_m = float(continuity_margin_m)
        # object -> where and when (percept time) it was last perceived: continuity's reference
        # (an action effect moves the belief, not this reference: see _jump)
        self.last_percept: dict[str, tuple[Vec3, float]] = {}
        self.version = 0  # bumped on every change; lets callers cache query results

    # -- objects ------------------------------------------------------------------------
    def add_object(
        self,
        obj_id: str,
        type: str,
        position: Iterable[float],
        size: Mapping[str, float] | None = None,
        **attrs: Any,
    ) -> ObjectRecord:
        if obj_id in self.objects:
            raise FlexhrcError(f"object {obj_id!r} already exists")
        rec = ObjectRecord(obj_id, type, _vec(position), dict(size or {}), dict(attrs))
        self.objects[obj_id] = rec
        self._facts.update((t, obj_id) for t in self.type_chain(type))
        self._facts_changed()
        self.version += 1
        return rec

    def type_chain(self, type: str) -> list[str]:
        """``type`` and its supertypes, most specific first (a cycle is an error)."""
        chain = [type]
        while chain[-1] in self.supertypes:
            parent = self.supertypes[chain[-1]]
            if parent in chain:
                raise FlexhrcError(f"supertypes form a cycle: {' -> '.join([*chain, parent])}")
            chain.append(parent)
        return chain

    def object(self, obj_id: str) -> ObjectRecord:
        try:
            return self.objects[obj_id]
        except KeyError:
            raise UnknownNameError(f"no object {obj_id!r} in the knowledge base") from None

    def position(self, obj_id: str) -> Vec3:
        return self.object(obj_id).position

    def move(self, obj_id: str, position: Iterable[float]) -> None:
        """An action effect: the object is now at ``position`` (not a percept: no check)."""
        self.object(obj_id).position = _vec(position)
        self.version += 1

    def set_fixed(self, obj_id: str, fixed: bool = True) -> None:
        self.object(obj_id).fixed = fixed
        self.version += 1

    def objects_of_type(self, type: str) -> list[ObjectRecord]:
        """Objects of ``type`` or of one of its subtypes."""
        return [o for o in self.objects.values() if type in self.type_chain(o.type)]

    # -- percepts -----------------------------------------------------------------------
    @property
    def consistent(self) -> bool:
        return not self.inconsistencies

    def update_object(
        self,
        obj_id: str,
        type: str,
        pose: Iterable[float],
        size: Mapping[str, float] | Iterable[float] | None = None,
        *,
        t: float | None = None,
        **attrs: Any,
    ) -> bool:
        """A percept of one object (the perception modules' ``ObjectSink`` protocol).

        ``pose`` starts with the position (a quaternion may follow); ``size`` is a mapping of
        named dimensions, or extents largest first (stored as ``length``, ``width``,
        ``height``); ``t`` is when it was perceived (s; needed for the continuity check). A new
        id is added; a known one is updated when the percept agrees with the base, and its
        pending inconsistencies are cleared (a compatible percept ends the inconsistent state,
        paper 000 VI-E). Returns False when the percept contradicts the base — another type,
        a size off, a fixed object elsewhere, a jump no agent could have made since the last
        percept: it is then kept as an :class:`Inconsistency` and nothing changes until
        :meth:`resolve` or a later compatible percept.
        """
        position = _vec(list(pose)[:3])
        size = _size(size)
        when = _time(t)
        percept: dict[str, Any] = {
            "type": type,
            "position": position,
            "size": dict(size or {}),
            "attrs": attrs,
        }
        if when is not None:
            percept["t"] = when
        rec = self.objects.get(obj_id)
        if rec is None:
            self.add_object(obj_id, type, position, size, **attrs)
            self._perceived(obj_id, position, when)
            return True
        reason = self._contradiction(rec, type, position, size or {}) or self._jump(
            rec, position, when
        )
        if reason:
            self.contradict(obj_id, reason, percept)
            return False
        rec.position = position
        if size:
            rec.size.update(size)
        rec.attrs.update(attrs)
        self._perceived(obj_id, position, when)
        self.version += 1
        return True

    def _contradiction(
        self, rec: ObjectRecord, type: str, position: Vec3, size: Mapping[str, float]
    ) -> str | None:
        if type != rec.type:
            return f"{rec.id} is a {rec.type}, perceived as a {type}"
        for k, v in size.items():
            known = rec.size.get(k)
            if known and abs(v - known) > self.size_tolerance * known:
                return f"{rec.id}: {k} {known:g} known, {v:g} perceived"
        if rec.fixed and math.dist(rec.position, position) > self.position_tolerance:
            return _fixed_elsewhere(rec, position)
        return None

    def _jump(self, rec: ObjectRecord, position: Vec3, t: float | None) -> str | None:
        """Continuity (paper 000, VI-E): is ``position`` at time ``t`` farther from the
        object's last percept than any agent could have carried it since, and not where an
        action left it? (A fixed object is checked against where it is fixed instead; an
        untimed percept is not checked.) A percept that confirms the belief is compatible
        however far the belief moved: an action's effect explains the change — in simulation
        it takes effect when the action ends, not along the way."""
        last = self.last_percept.get(rec.id)
        if t is None or last is None or rec.fixed or self.max_speed_m_s == _INF:
            return None
        (seen, seen_t), dt = last, abs(t - last[1])
        d = math.dist(seen, position)
        if d <= self.max_speed_m_s * dt + self.continuity_margin_m:
            return None
        if math.dist(rec.position, position) <= self.continuity_margin_m:
            return None
        return (
            f"{rec.id} perceived {d:.2f} m from where it was perceived {dt:.2f} s before "
            f"(at {format_position(seen)}, t={seen_t:g} s): no agent moves it faster than "
            f"{self.max_speed_m_s:g} m/s"
        )

    def _perceived(self, obj_id: str, position: Vec3, t: float | None) -> None:
        """A percept was applied: continuity's new reference, and what it contradicted is
        over (the base waited for this compatible information)."""
        if t is not None:
            self.last_percept[obj_id] = (position, t)
        if any(i.object_id == obj_id for i in self.inconsistencies):
            self.inconsistencies = [i for i in self.inconsistencies if i.object_id != obj_id]

    # -- anchoring --------------------------------------------------------------------------
    def add_symbol(
        self, obj_id: str, type: str, size: Mapping[str, float] | None = None, **attrs: Any
    ) -> ObjectRecord:
        """An object known by name and type but not where it is: perception anchors it.

        Its position reads as the origin until then (:attr:`ObjectRecord.anchored` is False);
        callers that plan with positions run perception first.
        """
        rec = self.add_object(obj_id, type, (0.0, 0.0, 0.0), size, **attrs)
        rec.anchored = False
        return rec

    def compatible(self, known: str, perceived: str) -> bool:
        """Can an object of type ``known`` be perceived as a ``perceived``? Yes when one is
        the other or a supertype of it (a ``leg`` seen as a ``leg_long``, and back)."""
        return known in self.type_chain(perceived) or perceived in self.type_chain(known)

    def observe(
        self,
        obj_id: str,
        position: Iterable[float],
        type: str | None = None,
        *,
        t: float | None = None,
    ) -> bool:
        """A percept anchored to the known symbol ``obj_id`` (perceived at time ``t``, s).

        Applied when it agrees with the base: the position is taken, the symbol is anchored and
        its pending inconsistencies are cleared (a later compatible percept ends the
        inconsistent state). The type stays: a partly hidden long leg may look like a short
        one, so a percept's subtype does not refine the symbol's.
        A percept of an incompatible type, of a fixed object elsewhere (horizontal distance
        above the position tolerance: a fixed object's height depends on what is fixed where),
        or of a loose object farther from its last percept than continuity allows, is kept as
        an :class:`Inconsistency` instead; returns False then.
        """
        rec = self.object(obj_id)
        pos = _vec(position)
        when = _time(t)
        percept: dict[str, Any] = {"type": type or rec.type, "position": pos, "size": {}}
        if when is not None:
            percept["t"] = when
        reason = None
        if type is not None and not self.compatible(rec.type, type):
            reason = f"{rec.id} is a {rec.type}, perceived as a {type}"
        elif rec.fixed and rec.anchored and _hdist(rec.position, pos) > self.position_tolerance:
            reason = _fixed_elsewhere(rec, pos)
        else:
            reason = self._jump(rec, pos, when)
        if reason:
            self.contradict(obj_id, reason, percept)
            return False
        rec.position = pos
        rec.anchored = True
        self._perceived(obj_id, pos, when)
        self.version += 1
        return True

    def contradict(self, obj_id: str, reason: str, percept: Mapping[str, Any]) -> Inconsistency:
        """Record an inconsistency found by the caller's own check (nothing else changes)."""
        self.object(obj_id)
        inc = Inconsistency(obj_id, reason, dict(percept))
        self.inconsistencies.append(inc)
        self.version += 1
        return inc

    def resolve(self, obj_id: str | None = None, *, accept: bool) -> None:
        """Decide pending inconsistencies (all, or those of one object): accept the percept
        (it overwrites the base, the object is no longer fixed) or reject it."""
        keep: list[Inconsistency] = []
        for inc in self.inconsistencies:
            if obj_id is not None and inc.object_id != obj_id:
                keep.append(inc)
                continue
            if accept:
                rec = self.objects[inc.object_id]
                self._facts.difference_update((t, rec.id) for t in self.type_chain(rec.type))
                rec.type = inc.percept["type"]
                rec.position = inc.percept["position"]
                rec.size.update(inc.percept["size"])
                rec.fixed = False
                self._facts.update((t, rec.id) for t in self.type_chain(rec.type))
                self._facts_changed()
                # the accepted percept is continuity's reference now (none, if it had no time)
                when = inc.percept.get("t")
                if isinstance(when, int | float):
                    self.last_percept[rec.id] = (rec.position, float(when))
                else:
                    self.last_percept.pop(rec.id, None)
        self.inconsistencies = keep
        self.version += 1

    # -- facts --------------------------------------------------------------------------
    def assert_fact(self, *fact: str) -> None:
        self._facts.add(tuple(fact))
        self._facts_changed()
        self.version += 1

    def retract_fact(self, *fact: str) -> None:
        self._facts.discard(tuple(fact))
        self._facts_changed()
        self.version += 1

    def holds(self, *fact: str) -> bool:
        return tuple(fact) in self._facts

    @property
    def facts(self) -> frozenset[tuple[str, ...]]:
        gen, kept = self._facts_gen, self._frozen
        if kept is not None and kept[0] == gen:
            return kept[1]
        frozen = frozenset(self._facts)
        self._frozen = (gen, frozen)
        return frozen

    def _facts_changed(self) -> None:
        """Called after ``_facts`` changed: the kept views are of older facts now. (They are
        replaced, never changed in place, so a query running over them stays consistent; one
        made while a change was under way is of the generation before it, never taken after.)"""
        self._facts_gen += 1

    def _facts_index(self) -> dict[str, list[tuple[str, ...]]]:
        gen, kept = self._facts_gen, self._index
        if kept is not None and kept[0] == gen:
            return kept[1]
        index = index_facts(self._facts)
        self._index = (gen, index)
        return index

    def query(
        self, formula: Iterable[Literal], subst: Mapping[str, str] | None = None
    ) -> list[Substitution]:
        """Every substitution making the conjunction true (closed world), deterministic order."""
        return list(satisfy(formula, self._facts, subst, index=self._facts_index()))

    def iter_query(
        self, formula: Iterable[Literal], subst: Mapping[str, str] | None = None
    ) -> Iterator[Substitution]:
        # a generator: the index is taken when the caller starts iterating, as satisfy's own
        yield from satisfy(formula, self._facts, subst, index=self._facts_index())

    def apply_effects(
        self, add: Conjunction, delete: Conjunction, subst: Mapping[str, str]
    ) -> None:
        """Action effects (eq. 20): delete first, then add, both grounded by ``subst``."""
        try:
            for lit in delete:
                self._facts.discard(apply_substitution(lit, subst).key())
            for lit in add:
                g = apply_substitution(lit, subst)
                if not g.is_ground:
                    raise FlexhrcError(f"effect {lit} is not ground under {dict(subst)}")
                self._facts.add(g.key())
        finally:  # (a refused effect may follow effects already applied)
            self._facts_changed()
        self.version += 1

    # -- copies -------------------------------------------------------------------------
    def copy(self) -> KnowledgeBase:
        """An independent copy (simulations run on copies)."""
        return copy.deepcopy(self)

    def to_dict(self) -> dict[str, Any]:
        return {
            "objects": [o.to_dict() for o in self.objects.values()],
            "facts": sorted(list(f) for f in self._facts),
            "consistent": self.consistent,
        }


def _size(size: Mapping[str, float] | Iterable[float] | None) -> dict[str, float]:
    if size is None:
        return {}
    if isinstance(size, Mapping):
        return {str(k): float(v) for k, v in size.items()}
    values = [float(v) for v in size]
    return dict(zip(("length", "width", "height"), values, strict=False))


def _time(t: float | None) -> float | None:
    if t is None:
        return None
    if isinstance(t, bool) or not isinstance(t, int | float) or not math.isfinite(t):
        raise FlexhrcError(f"the time of a percept must be a finite number of seconds, got {t!r}")
    return float(t)


def _vec(p: Iterable[float]) -> Vec3:
    # the common case, checked cheaply (every move); NaN and the infinities fail the
    # comparisons and take the general path
    if (type(p) is tuple or type(p) is list) and len(p) == 3:
        x, y, z = p
        if (
            type(x) is float
            and type(y) is float
            and type(z) is float
            and -_INF < x < _INF
            and -_INF < y < _INF
            and -_INF < z < _INF
        ):
            return (x, y, z)
    vals = [float(x) for x in p]
    if len(vals) != 3 or not all(math.isfinite(v) for v in vals):
        raise FlexhrcError(f"a position needs three finite numbers, got {vals}")
    return (vals[0], vals[1], vals[2])


def _hdist(a: Vec3, b: Vec3) -> float:
    return math.hypot(a[0] - b[0], a[1] - b[1])


def _fixed_elsewhere(rec: ObjectRecord, position: Vec3) -> str:
    at, seen = format_position(rec.position), format_position(position)
    return f"{rec.id} is fixed at {at} but perceived at {seen}"


def format_position(p: Iterable[float]) -> str:
    """A position as messages print it: ``(0.450, -0.120, 0.020)`` (metres, to the millimetre)."""
    return "(" + ", ".join(f"{float(v):.3f}" for v in p) + ")"
