"""The node base class and its update loop (paper 002, Algorithm 1).

Every node — goal or behaviour — runs the same loop once per clock tick::

    if not done:
        if active (level > τ_active):
            if preconditions: behaviour → acquire the arm mutex and run; goal → done
            else: spread activation to the children
        level ← α · level                         # activation fall-off
    publish the state message to the parent

A node knows only its own fields, its own name, its parent's and children's *names* and a
:class:`~flexhrc.transport.Transport`. Everything it learns about other nodes arrives as messages
(:mod:`flexhrc.behavior.messages`) through subscriptions whose callbacks only write this node's
own inbox fields; so a node can later run in its own thread or process (with a lock around the
inbox) without changing its logic.

Two modelling choices, documented here because the paper leaves them implicit:

* an activation message *sets* the child's level (the last message wins) — so a parent can give
  a child zero activation explicitly (the OR node does when it switches alternative), and a child
  nobody feeds decays as α^k and drops below τ_active after a few ticks;
* state messages are published when the state, potential, progress or engagement *changed*
  (latched topic semantics): a parent keeps the last value it heard. It saves almost all
  messages of idle nodes and does not change what any parent knows.

A node whose update loop would do nothing — inactive (or done), below τ_active, nothing new in its
inbox — is *quiescent* (:meth:`Node.busy` is false). Like a node thread blocking on its inbox, an
executor may then skip it until a message (or, for a behaviour, a change of what it senses) wakes
it through the *waker* callback (:meth:`Node.set_waker`). Only its sub-threshold activation level
is not decayed while it sleeps; that has no effect (it is below τ, and the next activation
message sets it anyway).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from flexhrc.behavior.messages import (
    LOG_TOPIC,
    ActivationMsg,
    ActivationRelease,
    LogEvent,
    StateMsg,
    activation_topic,
    state_topic,
)
from flexhrc.behavior.params import NetworkParams, NodeState
from flexhrc.transport.base import Transport

INACTIVE = NodeState.INACTIVE.value
ACTIVE = NodeState.ACTIVE.value
RUNNING = NodeState.RUNNING.value
DONE = NodeState.DONE.value


class Node:
    """Base of goal and behaviour nodes: state, activation level, activation potential."""

    kind = "NODE"

    def __init__(self, name: str, transport: Transport, params: NetworkParams) -> None:
        self.name = name
        self.state: str = INACTIVE
        self.level = 0.0
        self.potential = 0.0
        #: True once a behaviour of this sub-task is running or done (reported to the parent).
        self.progress = False
        self._transport = transport
        self._tau = params.tau_active
        self._alpha = params.falloff
        self._params = params
        self._state_topic = state_topic(name)
        #: A held (latched) activation level, re-applied at every update loop; None if none.
        self._held: float | None = None
        self._activation_sub = transport.subscribe(activation_topic(name), self._on_activation)
        self._last_published: tuple[str, float, bool, bool] | None = None
        self.tick = 0
        self.now = 0.0
        self._waker: Callable[[int], None] | None = None
        self._slot = -1

    # -- inbox ---------------------------------------------------------------------------------
    def set_waker(self, waker: Callable[[int], None] | None, slot: int = -1) -> None:
        """Have ``waker(slot)`` called whenever something arrives in this node's inbox."""
        self._waker = waker
        self._slot = slot

    def wake(self) -> None:
        if self._waker is not None:
            self._waker(self._slot)

    def _on_activation(self, msg: ActivationMsg | ActivationRelease) -> None:
        if isinstance(msg, ActivationRelease):
            self._held = None
        else:
            self.level = msg.level
            self._held = msg.level if msg.hold else None
        if self._waker is not None:
            self._waker(self._slot)

    def busy(self) -> bool:
        """Must run next tick even with an empty inbox (active, running, or above τ; a done node
        has nothing left to do)."""
        state = self.state
        return state in (ACTIVE, RUNNING) or (self.level > self._tau and state != DONE)

    def disconnect_parent(self) -> None:
        """Stop listening to the parent (a broken link); the level then only decays."""
        self._activation_sub.cancel()
        self._held = None
        self.wake()  # a held level now decays: the node has work again

    # -- Algorithm 1 ---------------------------------------------------------------------------
    def update(self, tick: int, now: float) -> None:
        self.tick = tick
        self.now = now
        if self._held is not None:
            self.level = self._held
        if self.state == DONE:
            self.idle_done()
            return
        self.update_potential()
        if self.state == RUNNING:
            self.run()
        elif self.level > self._tau:
            if self.state != ACTIVE:
                self.set_state(ACTIVE)
            if self.preconditions():
                self.activate()
            else:
                self.spread()
        else:
            if self.state != INACTIVE:
                self.set_state(INACTIVE)
                self.on_deactivate()
            self.deactivated()
        if self.state != DONE:
            self.level *= self._alpha
        self.publish_state()

    # -- hooks (overridden by goal and behaviour nodes) -----------------------------------------
    def update_potential(self) -> None:
        """Bottom-up activation potential (Algorithms 5–8)."""

    def preconditions(self) -> bool:
        return False

    def activate(self) -> None:
        """Preconditions hold: a goal finishes, a behaviour starts running."""

    def spread(self) -> None:
        """Top-down activation spreading (Algorithms 2–4)."""

    def run(self) -> None:
        """One tick of a running behaviour."""

    def on_deactivate(self) -> None:
        """Called once when the node drops below τ_active."""

    def deactivated(self) -> None:
        """Called every tick the node is inactive."""

    def engaged(self) -> bool:
        """Whether this node (or, for goals, its sub-tree) may still act: active or running."""
        return self.state == ACTIVE or self.state == RUNNING

    def idle_done(self) -> None:
        """Called every tick once done."""

    # -- publishing ----------------------------------------------------------------------------
    def set_state(self, new: str, **data: Any) -> None:
        old = self.state
        self.state = new
        self.emit("state", node_kind=self.kind, frm=old, to=new, **data)

    def publish_state(self) -> None:
        engaged = self.engaged()
        key = (self.state, self.potential, self.progress, engaged)
        if key != self._last_published:
            self._last_published = key
            self._transport.publish(
                self._state_topic,
                StateMsg(
                    self.name,
                    self.state,
                    self.level,
                    self.potential,
                    self.progress,
                    engaged,
                    self.tick,
                ),
            )

    def emit(self, kind: str, **data: Any) -> None:
        """Publish a trace record on the log topic (no node reads it; the runner records it)."""
        self._transport.publish(LOG_TOPIC, LogEvent(self.tick, self.now, self.name, kind, data))

    def snapshot(self) -> dict[str, Any]:
        """The node's own fields, for tests, rendering and debugging (never read by other nodes)."""
        return {
            "name": self.name,
            "kind": self.kind,
            "state": self.state,
            "level": self.level,
            "potential": self.potential,
            "progress": self.progress,
        }

    def __repr__(self) -> str:
        return (
            f"<{self.kind} {self.name} {self.state} "
            f"level={self.level:.3g} potential={self.potential:.3g}>"
        )
