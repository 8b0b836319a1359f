"""THEN, AND and OR goal nodes (paper 002, Algorithms 2–7).

Top-down, a goal node *spreads activation* to its children while its own preconditions are not
met:

* THEN (Algorithm 2) sends level 1.0 to its first child that is not done — sequencing;
* AND (Algorithm 3) sends 1/n to all its children (or a fixed level, see
  :class:`~flexhrc.behavior.params.NetworkParams.and_spread`) — they race for the arm mutex;
* OR (Algorithm 4) sends 1.0 to the child with the highest activation potential and zero to the
  others. Ties are broken by a seeded random choice that then sticks; once a child reports
  progress (a behaviour of it runs or ran) the OR commits to it.

Exactly one alternative of an OR is ever carried out, even with two arms and message latency,
because switching is *safe*: when the best alternative changes, the OR first sends zero to the
old one and only activates the new one once the old one reports it is no longer *engaged* (no
node in it active or running; a goal counts as engaged for two ticks after it last gave
activation, the round trip of a message). A goal node that drops below τ_active sends zero to
its children at once, so a cut-off sub-tree goes quiet in one tick per level instead of waiting
for the fall-off. If a behaviour of the old alternative started meanwhile, its progress arrives
first and the OR commits back to it.

Bottom-up, a goal node combines its children's *activation potential*: OR the maximum
(Algorithm 5), AND and THEN the mean (Algorithms 6 and 7).

Preconditions: THEN and AND are satisfied when every child is done, OR when one child is done;
then the goal node sets itself done (Algorithm 1, "GOAL NODE: Activate").

Done children are not sent activation any more (they would ignore it): that keeps a finished
sub-tree silent.
"""

from __future__ import annotations

import random
from collections.abc import Sequence

from flexhrc.behavior.messages import ActivationMsg, StateMsg, activation_topic, state_topic
from flexhrc.behavior.node import ACTIVE, DONE, INACTIVE, Node
from flexhrc.behavior.params import NetworkParams
from flexhrc.transport.base import Transport


class GoalNode(Node):
    """Common part of THEN/AND/OR: the children's last reported state, potential and progress."""

    kind = "GOAL"

    def __init__(
        self, name: str, children: Sequence[str], transport: Transport, params: NetworkParams
    ) -> None:
        super().__init__(name, transport, params)
        if not children:
            raise ValueError(f"goal node {name} needs children")
        self.children: tuple[str, ...] = tuple(children)
        n = len(self.children)
        self._index = {c: i for i, c in enumerate(self.children)}
        self._child_state = [INACTIVE] * n
        self._child_potential = [0.0] * n
        self._child_progress = [False] * n
        self._child_engaged = [False] * n
        self._any_child_engaged = False
        self._fed_until = -1  # engaged until this tick because activation may still be in flight
        self._done_count = 0
        self._dirty = True
        self._child_topics = [activation_topic(c) for c in self.children]
        self._latched = params.latched
        self._full = ActivationMsg(name, 1.0, self._latched)
        self._zero = ActivationMsg(name, 0.0)
        #: Children currently holding a latched activation from this node.
        self._holding = [False] * n
        self._slept = False  # skipped by the executor while settled (see busy())
        for c in self.children:
            transport.subscribe(state_topic(c), self._on_child_state)

    def _on_child_state(self, msg: StateMsg) -> None:
        i = self._index[msg.sender]
        if msg.state == DONE and self._child_state[i] != DONE:
            self._done_count += 1
        self._child_state[i] = msg.state
        self._child_potential[i] = msg.potential
        self._child_progress[i] = msg.progress
        self._child_engaged[i] = msg.engaged
        self._dirty = True
        if self._waker is not None:
            self._waker(self._slot)

    def update_potential(self) -> None:
        if self._dirty:
            self._dirty = False
            self.potential = self.combine(self._child_potential)
            self.progress = any(self._child_progress)
            self._any_child_engaged = any(self._child_engaged)

    def engaged(self) -> bool:
        return self.state == ACTIVE or self._any_child_engaged or self.tick <= self._fed_until

    def update(self, tick: int, now: float) -> None:
        if self._slept:
            self._slept = False
            if tick > self.tick + 1:
                # Asleep while settled, it would have spread at every loop: activation was last
                # "sent" in the previous loop, so it stays engaged for that round trip.
                self._fed_until = max(self._fed_until, tick + 1)
        # Fast path, exactly equivalent to Algorithm 1 for an idle goal: inactive, below τ,
        # nothing new from the children, no activation in flight, nothing to re-publish.
        if self._held is not None:
            self.level = self._held
        last = self._last_published
        if (
            self.state == INACTIVE
            and self.level <= self._tau
            and not self._dirty
            and tick > self._fed_until
            and last is not None
            and last[3] == self._any_child_engaged
        ):
            self.tick = tick
            self.now = now
            self.level *= self._alpha
            return
        super().update(tick, now)

    def busy(self) -> bool:
        # Stay awake while the round trip of the last activation sent is not over, so the change
        # of `engaged` is published.
        if self.state == DONE:
            return False  # a done goal ignores everything (Algorithm 1)
        if (
            self._latched
            and self.state == ACTIVE
            and self._held is not None
            and not self._dirty
            and self.settled()
        ):
            # Active, held by its parent, its children held: every loop would send nothing and
            # publish nothing until a message arrives — asleep (see update()).
            self._slept = True
            return False
        return super().busy() or self._dirty or self.tick <= self._fed_until

    def settled(self) -> bool:
        """Latched spreading has reached a fixed point (every child it feeds holds its level)."""
        return False

    def send(self, i: int, msg: ActivationMsg) -> None:
        """Send activation to child ``i``; a positive level keeps this node engaged for the
        round trip of the message."""
        if msg.level > 0:
            self._fed_until = self.tick + 2
        if self._latched:
            if self._holding[i]:
                return  # the child holds this level already: as good as sending it again
            self._holding[i] = msg.hold
        self._transport.publish(self._child_topics[i], msg)

    def send_zero(self, i: int) -> None:
        """Give child ``i`` zero activation (also ends a held level)."""
        self._holding[i] = False
        self._transport.publish(self._child_topics[i], self._zero)

    def on_deactivate(self) -> None:
        # Cut-off propagates at once: children this node fed lose their activation explicitly.
        for i in range(len(self.children)):
            if self._child_state[i] != DONE:
                self.send_zero(i)

    def combine(self, potentials: list[float]) -> float:
        """Algorithms 6–7: mean of the children's potentials (OR overrides with the max)."""
        return sum(potentials) / len(potentials)

    def preconditions(self) -> bool:
        return self._done_count == len(self.children)

    def activate(self) -> None:
        self.set_state(DONE)

    def snapshot(self) -> dict[str, object]:
        snap = super().snapshot()
        snap["children"] = list(self.children)
        return snap


class ThenNode(GoalNode):
    """Sequence: activation goes to the first child not yet done (Algorithm 2)."""

    kind = "THEN"

    _first = 0  # children before this index are done (done is final), so the scan is O(1)

    def spread(self) -> None:
        states = self._child_state
        i = self._first
        while i < len(states) and states[i] == DONE:
            i += 1
        self._first = i
        if i < len(states):
            self.send(i, self._full)

    def settled(self) -> bool:
        i = self._first
        return i < len(self._holding) and self._holding[i] and self._child_state[i] != DONE


class AndNode(GoalNode):
    """No ordering: every child gets activation at once (Algorithm 3)."""

    kind = "AND"

    def __init__(
        self, name: str, children: Sequence[str], transport: Transport, params: NetworkParams
    ) -> None:
        super().__init__(name, children, transport, params)
        n = len(self.children)
        divided = 1.0 / n
        if params.and_spread == "fixed" or (
            params.and_spread == "auto" and divided <= params.tau_active
        ):
            level = params.and_level
        else:
            level = divided
        #: The level each child receives (1/n, or the fixed level for large ANDs).
        self.child_level = level
        self._msg = ActivationMsg(name, level, self._latched)
        self._all_held = False  # latched: every child not done holds the level

    def spread(self) -> None:
        self._fed_until = self.tick + 2
        if self._latched and self._all_held:
            return
        states = self._child_state
        publish = self._transport.publish
        topics = self._child_topics
        msg = self._msg
        holding = self._holding
        for i in range(len(states)):
            if states[i] != DONE and not holding[i]:
                publish(topics[i], msg)
                holding[i] = self._latched
        self._all_held = self._latched

    def on_deactivate(self) -> None:
        super().on_deactivate()
        self._all_held = False

    def settled(self) -> bool:
        return self._all_held


class OrNode(GoalNode):
    """Alternatives: activation goes to the child with the highest potential (Algorithm 4)."""

    kind = "OR"

    def __init__(
        self, name: str, children: Sequence[str], transport: Transport, params: NetworkParams
    ) -> None:
        super().__init__(name, children, transport, params)
        # String seeds are hashed with SHA-512 by `random`, so this is stable across processes.
        self._rng = random.Random(f"{params.seed}:{name}")
        #: Index of the child currently given activation (None before the first spread or while
        #: switching).
        self.chosen: int | None = None
        self._leaving: int | None = None  # alternative switched away from, until it is quiet
        self._left_at = -1

    def combine(self, potentials: list[float]) -> float:
        """Algorithm 5: an OR is as good as its best alternative."""
        return max(potentials)

    def preconditions(self) -> bool:
        return self._done_count > 0

    def choose(self) -> int:
        progress = self._child_progress
        for i in range(len(progress)):
            if progress[i]:
                return i  # committed: this pathway has started
        pots = self._child_potential
        best = max(pots)
        ties = [i for i in range(len(pots)) if pots[i] >= best - 1e-12 * max(1.0, abs(best))]
        if len(ties) == 1:
            return ties[0]
        if self.chosen in ties:
            return self.chosen  # keep a tie decision once taken (no flip-flopping)
        return self._rng.choice(ties)

    def spread(self) -> None:
        target = self.choose()
        if self.chosen is not None and target != self.chosen:
            # Switch safely: silence the old alternative first (see the module docstring).
            self.send_zero(self.chosen)
            self._leaving, self._left_at = self.chosen, self.tick
            self.chosen = None
        if self.chosen is None:
            leaving = self._leaving
            if (
                leaving is not None
                and leaving != target
                and (self._child_engaged[leaving] or self.tick <= self._left_at + 2)
            ):
                return  # wait until the old alternative has gone quiet
            self._leaving = None
            self.chosen = target
            self.emit("choose", child=self.children[target])
        self.send(self.chosen, self._full)

    def settled(self) -> bool:
        chosen = self.chosen
        return chosen is not None and self._leaving is None and self._holding[chosen]


GOAL_CLASSES: dict[str, type[GoalNode]] = {"THEN": ThenNode, "AND": AndNode, "OR": OrNode}
