"""Anchoring percepts to the knowledge base's symbols (paper 000, VI-D).

Scene perception names what it sees per frame (``c0``, ``c1`` ...); the Task Manager reasons
about symbols (``leg2``, ``tabletop``). :class:`Anchoring` keeps the two joined, frame after
frame, with a gated optimal assignment (Hungarian, ``scipy.optimize.linear_sum_assignment``):

1. **Anchoring** — a percept and a symbol may pair only when their types are compatible (equal,
   or one a supertype of the other: the knowledge base's ``supertypes``); the cost is their
   horizontal distance (objects on a table: how high a part is depends on how it is held), and
   pairs farther apart than the gate ``gate_m`` (for a fixed part: twice the base's position
   tolerance) are never made. A symbol whose position is not
   known yet (:meth:`~flexhrc.knowledge.KnowledgeBase.add_symbol`) pairs with any compatible
   percept at the cost of the gate, so a known position always wins.
2. **Continuity** — percepts left over are paired again, without the gate, with the symbols left
   over that have been seen before. A symbol whose belief a caller asked to check
   (:meth:`Anchoring.expect`: e.g. where a reported human action left it) but that is still
   seen where it was is an inconsistency: the belief is wrong (e.g. a false report). A non-fixed
   object seen farther from where it was last seen than any agent could have carried it in the
   meantime (``max_speed_m_s`` — by default the base's own bound,
   :attr:`~flexhrc.knowledge.KnowledgeBase.max_speed_m_s` — times the time elapsed, plus the
   gate) is an inconsistency too; every percept goes to the base with the frame's time, and the
   base checks continuity itself as well (paper 000, VI-E).
   Otherwise the object has moved and is re-anchored at its new place (``moved`` in the report:
   a Task Manager stops the actions that use it, paper 002's validity check).
3. **New objects** — percepts still left become new symbols with stable names (``leg_1``, the
   root of the type's supertype chain and a counter), asserted into the base.
4. **Missing** — a symbol not seen for ``missing_after`` frames in a row is reported missing
   (once, until it is seen again).

The base records every inconsistency (:meth:`~flexhrc.knowledge.KnowledgeBase.contradict`) and
the Task Manager waits while there is one; a later percept compatible with the belief clears it
(:meth:`~flexhrc.knowledge.KnowledgeBase.observe`). SciPy is imported when the first frame comes.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from flexhrc.knowledge import KnowledgeBase, ObjectRecord
from flexhrc.knowledge.base import format_position
from flexhrc.perception._deps import require
from flexhrc.perception.scene.types import DetectedObject

_BIG = 1e9


@dataclass
class AnchoringReport:
    """What one frame did to the knowledge base."""

    frame: int
    t: float
    anchored: dict[str, str] = field(default_factory=dict)  # symbol -> percept id of the frame
    new_objects: list[str] = field(default_factory=list)
    moved: list[str] = field(default_factory=list)  # re-anchored away from the belief
    missing: list[str] = field(default_factory=list)  # reported missing at this frame
    inconsistencies: list[str] = field(default_factory=list)  # reasons found at this frame
    cleared: list[str] = field(default_factory=list)  # symbols a compatible percept cleared
    ignored: int = 0  # percepts of no known type

    def to_dict(self) -> dict[str, Any]:
        return {**asdict(self), "t": round(self.t, 6)}


class Anchoring:
    """Keeps percepts anchored to the symbols of ``kb``, frame after frame.

    ``types``: the object types perception can report (e.g. ``RuleSet.types``); the symbols
    considered are the base's objects of a compatible type. ``on_new(record)`` is called for
    every new object (e.g. to assert scenario facts about it).
    """

    def __init__(
        self,
        kb: KnowledgeBase,
        types: Iterable[str],
        *,
        gate_m: float = 0.10,
        max_speed_m_s: float | None = None,
        missing_after: int = 3,
        move_threshold_m: float = 0.03,
        on_new: Callable[[ObjectRecord], None] | None = None,
    ):
        for name, v in (
            ("gate_m", gate_m),
            ("max_speed_m_s", max_speed_m_s if max_speed_m_s is not None else 1.0),
            ("move_threshold_m", move_threshold_m),
        ):
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {v!r}")
        if not isinstance(missing_after, int) or missing_after < 1:
            raise ValueError(f"missing_after must be a whole number >= 1, got {missing_after!r}")
        self.kb = kb
        self.types = list(dict.fromkeys(types))
        self.gate_m = float(gate_m)
        # the base's bound unless told otherwise (math.inf there: continuity is not checked)
        self.max_speed_m_s = float(kb.max_speed_m_s if max_speed_m_s is None else max_speed_m_s)
        self.missing_after = missing_after
        self.move_threshold_m = float(move_threshold_m)
        self.on_new = on_new
        self.frame = 0
        self.last_seen: dict[str, tuple[tuple[float, float, float], float]] = {}
        self.misses: dict[str, int] = {}
        self.reported_missing: set[str] = set()
        self.expected: set[str] = set()  # beliefs the next percepts must confirm

    def expect(self, symbol: str) -> None:
        """The belief about ``symbol`` comes from an uncertain source (a recognised human
        action): the next percept must confirm it, or it is an inconsistency. Other beliefs
        (predicted effects of acknowledged robot actions) simply follow the percept."""
        self.kb.object(symbol)
        self.expected.add(symbol)

    # -- helpers --------------------------------------------------------------------------
    def perceivable(self, rec: ObjectRecord) -> bool:
        return any(self.kb.compatible(rec.type, t) for t in self.types)

    def symbols(self) -> list[ObjectRecord]:
        """The base's objects perception can see, in a stable order."""
        return [o for _, o in sorted(self.kb.objects.items()) if self.perceivable(o)]

    def _known(self, percept_type: str) -> bool:
        return any(self.kb.compatible(t, percept_type) for t in self.types)

    @staticmethod
    def _h(a: Any, b: Any) -> float:
        return math.hypot(float(a[0]) - float(b[0]), float(a[1]) - float(b[1]))

    def _predicted(self, rec: ObjectRecord) -> bool:
        """Is the belief one to check, away from where the object was last seen?"""
        seen = self.last_seen.get(rec.id)
        return (
            rec.id in self.expected
            and seen is not None
            and self._h(seen[0], rec.position) > self.gate_m
        )

    def _assign(
        self,
        percepts: Sequence[DetectedObject],
        symbols: Sequence[ObjectRecord],
        cost: Callable[[DetectedObject, ObjectRecord], float | None],
    ) -> list[tuple[int, int]]:
        """The optimal pairs ``(percept index, symbol index)`` of compatible types (Hungarian
        assignment); ``cost`` None: the pair is never made."""
        if not percepts or not symbols:
            return []
        optimize = require("scipy.optimize", "anchoring percepts")
        matrix = np.full((len(percepts), len(symbols)), _BIG)
        for i, p in enumerate(percepts):
            for j, s in enumerate(symbols):
                c = cost(p, s) if self.kb.compatible(s.type, p.type) else None
                if c is not None:
                    matrix[i, j] = c
        rows, cols = optimize.linear_sum_assignment(matrix)
        return [(int(r), int(c)) for r, c in zip(rows, cols, strict=True) if matrix[r, c] < _BIG]

    # -- one frame ------------------------------------------------------------------------
    def update(self, percepts: Sequence[DetectedObject], now: float) -> AnchoringReport:
        """Anchor one frame's percepts at time ``now`` (s); updates the base."""
        if not math.isfinite(now):
            raise ValueError(f"the time of a frame must be finite, got {now!r}")
        self.frame += 1
        report = AnchoringReport(self.frame, float(now))
        good = [p for p in percepts if p.type != "unknown" and self._known(p.type)]
        report.ignored = len(percepts) - len(good)
        symbols = self.symbols()
        unmatched = {s.id for s in symbols}
        was_inconsistent = {i.object_id for i in self.kb.inconsistencies}

        # 1. gated assignment against the belief
        def belief_cost(p: DetectedObject, s: ObjectRecord) -> float | None:
            if not s.anchored:
                return self.gate_m
            d = self._h(p.position, s.position)
            # a fixed part cannot have moved: only a percept where it is can be it
            gate = 2 * self.kb.position_tolerance if s.fixed else self.gate_m
            return d if d <= gate + (0.0 if s.fixed else self._hidden(s, p) / 2) else None

        pairs = self._assign(good, symbols, belief_cost)
        for i, j in pairs:
            p, s = good[i], symbols[j]
            partial = s.anchored and self._hidden(s, p) > 0.0
            shift = self._h(p.position, s.position) if s.anchored else 0.0
            ok = self._apply(s, p, now, report, keep_position=partial)
            if ok and not partial and shift > self.move_threshold_m:
                report.moved.append(s.id)
            unmatched.discard(s.id)
        paired = {i for i, _ in pairs}

        # 2. continuity: what is left, against where it was last seen
        left = [p for i, p in enumerate(good) if i not in paired]
        olds = [s for s in symbols if s.id in unmatched and s.id in self.last_seen and not s.fixed]
        pairs = self._assign(left, olds, lambda p, s: self._h(p.position, self.last_seen[s.id][0]))
        for i, j in pairs:
            unmatched.discard(olds[j].id)
            self._continuity(olds[j], left[i], now, report)
        paired = {i for i, _ in pairs}
        left = [p for i, p in enumerate(left) if i not in paired]

        # a fixed part left unseen, and a percept near it that nothing else explains: the
        # fixed part is not where it is fixed (kb.observe records the inconsistency)
        fixed = [s for s in symbols if s.id in unmatched and s.fixed and s.anchored]
        for s in fixed:
            near = [
                p
                for p in left
                if self.kb.compatible(s.type, p.type)
                and self._h(p.position, s.position) <= self.gate_m
            ]
            if near:
                p = min(near, key=lambda q: self._h(q.position, s.position))
                left.remove(p)
                unmatched.discard(s.id)
                self._apply(s, p, now, report)

        # 3. new objects
        for p in left:
            name = self._new_name(p.type)
            rec = self.kb.add_object(name, p.type, _xyz(p.position), _extents(p.size))
            report.new_objects.append(name)
            self._seen(rec, p, now, report)
            if self.on_new is not None:
                self.on_new(rec)

        # 4. missing
        for sid in sorted(unmatched):
            n = self.misses.get(sid, 0) + 1
            self.misses[sid] = n
            if n >= self.missing_after and sid not in self.reported_missing:
                self.reported_missing.add(sid)
                report.missing.append(sid)
        still = {i.object_id for i in self.kb.inconsistencies}
        report.cleared = sorted(was_inconsistent - still)
        return report

    def _seen(
        self, s: ObjectRecord, p: DetectedObject, now: float, report: AnchoringReport
    ) -> None:
        self.expected.discard(s.id)  # confirmed, or re-anchored: nothing left to check
        report.anchored[s.id] = p.id
        self.last_seen[s.id] = (_xyz(p.position), float(now))
        self.misses[s.id] = 0
        self.reported_missing.discard(s.id)

    def _hidden(self, s: ObjectRecord, p: DetectedObject) -> float:
        """How much shorter than the symbol's known size the percept is (m): a part partly
        hidden (by an arm) is seen shorter, and its centre shifted by up to half that."""
        known = max((float(v) for v in s.size.values() if isinstance(v, int | float)), default=0.0)
        seen = float(np.max(p.size)) if len(p.size) else 0.0
        short = known - seen
        return short if short > 0.1 * known else 0.0

    def _apply(
        self,
        s: ObjectRecord,
        p: DetectedObject,
        now: float,
        report: AnchoringReport,
        keep_position: bool = False,
    ) -> bool:
        """A gated match: the percept agrees with the belief (or anchors a new symbol). A
        partial percept (``keep_position``) confirms the symbol without moving it."""
        position = s.position if keep_position else _xyz(p.position)
        ok = self.kb.observe(s.id, position, p.type, t=now)
        if ok:
            self._seen(s, p, now, report)
            if keep_position:
                self.last_seen[s.id] = (s.position, float(now))
        else:
            report.inconsistencies.append(self.kb.inconsistencies[-1].reason)
        return ok

    def _continuity(
        self, s: ObjectRecord, p: DetectedObject, now: float, report: AnchoringReport
    ) -> None:
        seen_at, seen_t = self.last_seen[s.id]
        pos = _xyz(p.position)
        if self._hidden(s, p) > 0.0 and self._h(pos, seen_at) <= self.gate_m + self._hidden(s, p):
            self._apply(s, p, now, report, keep_position=True)  # seen, partly hidden
            return
        percept = {"type": p.type, "position": pos, "size": _extents(p.size)}
        reason = None
        if self._predicted(s) and self._h(pos, seen_at) < self._h(pos, s.position):
            reason = (
                f"{s.id} should be at {format_position(s.position)} after what was done, "
                f"but is still seen at {format_position(pos)}"
            )
        else:
            d = self._h(pos, seen_at)
            dt = max(0.0, float(now) - seen_t)
            reach = self.max_speed_m_s * dt + self.gate_m
            if not s.fixed and d > reach:
                reason = (
                    f"{s.id} seen {d:.2f} m from where it was {dt:.2f} s ago: no agent "
                    f"moves it faster than {self.max_speed_m_s:g} m/s"
                )
        if reason is not None:
            if not any(i.object_id == s.id for i in self.kb.inconsistencies):
                self.kb.contradict(s.id, reason, percept)
                report.inconsistencies.append(reason)
            self.misses[s.id] = 0  # it is seen, only not where it should be
            return
        if self._apply(s, p, now, report):
            report.moved.append(s.id)

    def _new_name(self, type: str) -> str:
        base = self.kb.type_chain(type)[-1]
        k = 1
        while f"{base}_{k}" in self.kb.objects:
            k += 1
        return f"{base}_{k}"


def _xyz(p: Any) -> tuple[float, float, float]:
    return (float(p[0]), float(p[1]), float(p[2]))


def _extents(size: Any) -> dict[str, float]:
    names = ("length", "width", "height")
    return {n: round(float(v), 4) for n, v in zip(names, size, strict=False)}


__all__ = ["Anchoring", "AnchoringReport"]
