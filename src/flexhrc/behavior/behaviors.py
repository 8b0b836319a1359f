"""Behaviour (leaf) nodes and the PickAndPlace behaviour (paper 002, Sec. III-E, Algorithms 8–9).

A behaviour node's preconditions (Algorithm 9) are ``ObjectInView()`` and holding an arm mutex.
Acquiring a mutex is a message exchange, not a function call: while active and waiting, the node
sends a lock request to every arm's mutex each tick, bidding its activation potential *for that
arm*. When a grant arrives and the node is still active, it keeps the grant of its best arm,
releases any other, and starts running (Algorithm 1, "BEHAVIOR NODE: Activate"). A grant that
arrives too late (the node lost its activation, or is already running/done) is released at once.

While running, the node advances its action; for PickAndPlace a :class:`ValidityCheck` watches
the object until it is grasped (Sec. III-F). On completion the node is done and releases the
mutex; on a failed check it aborts the arm, releases the mutex and resets.

A running behaviour keeps running even if its activation falls (the paper's action thread runs
"unhindered"): stopping a half-done grasp because a parent changed its mind would be worse.

PickAndPlace's activation potential (Algorithm 8) is ``1 / ||x_obj - x_arm||``, with the nearest
arm when there are two — so the closest object wins the mutex bidding, and an OR prefers its
closest alternative. ``x_arm`` is where the arm will be when it is next free (its rest pose at
the end of a pick-and-place, its actual position when idle — e.g. where a reset stopped it):
that is where the next behaviour would start from, and it keeps potentials (and OR choices) from
flickering while an arm sweeps across the table.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

from flexhrc.behavior.messages import (
    MutexRelease,
    MutexReply,
    MutexRequest,
    MutexWithdraw,
    release_topic,
    reply_topic,
    request_topic,
)
from flexhrc.behavior.node import ACTIVE, DONE, INACTIVE, RUNNING, Node
from flexhrc.behavior.params import NetworkParams
from flexhrc.behavior.validity import ValidityCheck
from flexhrc.behavior.world import PickAndPlaceMotion, TabletopWorld
from flexhrc.transport.base import Transport


class PeerGate(Protocol):
    """What a behaviour asks before it starts when several robots share the task."""

    def blocked(self, behavior: str) -> bool:
        """Another robot holds or completed it, or a rival OR alternative: do not compete."""
        ...

    def permits(self, behavior: str) -> bool | None:
        """Claim ``behavior`` (this robot has won an arm for it): True = claimed by every live
        robot, go; None = still asking; False = refused."""
        ...

    def finished(self, behavior: str) -> None:
        """It completed here: tell the others (and release the claim)."""
        ...

    def released(self, behavior: str) -> None:
        """It was reset here (validity checking): release the claim."""
        ...


class BehaviorNode(Node):
    """A leaf that needs an arm: mutex bidding, running, done/reset; subclasses add the action.

    Write your own behaviour by subclassing and overriding the hooks (see ``docs/behavior.md``,
    "Your own behaviours", and ``examples/custom_behavior.py``):

    * :meth:`ready` — the preconditions besides holding an arm (Algorithm 9's ObjectInView);
    * :meth:`bid` — the activation potential for one arm (Algorithm 8); the node's potential,
      reported to its parent, is its best bid;
    * :meth:`start_action` — the mutex of ``arm`` is won: start (returns data for the log);
    * :meth:`step_action` — once per tick while running: ``"running"``, ``"done"``, or
      ``"invalid"`` when validity checking fails (the node then resets and competes again);
    * :meth:`abort_action` — stop the action after ``"invalid"`` (returns data for the log).

    ``obj`` names the object the behaviour works on — the one validity checking watches
    (:class:`~flexhrc.behavior.validity.ValidityCheck`) and whose sensing wakes the node. The
    node's clock is ``self.now`` (simulated seconds) and its parameters ``self._params``.

    Set :attr:`sleeps_while_waiting` only if :meth:`ready` and :meth:`bid` change *only* when
    the world senses a change of ``obj`` or of an arm: a waiting node then sleeps until woken,
    as PickAndPlace does; otherwise (the default) it is updated every tick while active.
    """

    kind = "BEHAVIOR"
    #: May the executor skip this node while it waits for an arm (see the class docstring)?
    sleeps_while_waiting = False

    def __init__(
        self,
        name: str,
        arms: Sequence[str],
        transport: Transport,
        params: NetworkParams,
        obj: str | None = None,
    ) -> None:
        super().__init__(name, transport, params)
        #: The object this behaviour works on (validity checking, sensing), or None.
        self.object: str | None = obj
        self.arms: tuple[str, ...] = tuple(arms)
        self.arm: str | None = None  # the arm whose mutex this node holds while running
        self.resets = 0
        self._grants: list[str] = []
        self._release = MutexRelease(name)
        self.bids: dict[str, float] = {a: 0.0 for a in self.arms}
        #: (arm, the topic its mutex hears requests on), for bidding.
        self._requests = [(a, request_topic(a)) for a in self.arms]
        self._latched = params.latched
        #: Latched protocol: the bids the mutexes hold for this node (None: no standing bid).
        self._standing: dict[str, float] | None = None
        self._bid_tick = -1  # the last update loop in which this node bid
        self._withdraw_msg = MutexWithdraw(name)
        #: Shares this behaviour with other robots (:class:`flexhrc.behavior.peers.PeerLink`):
        #: a claim is needed before it starts; None for a robot on its own.
        self.gate: PeerGate | None = None
        self._done_by: str | None = None  # another robot completed this behaviour
        transport.subscribe(reply_topic(name), self._on_reply)

    # -- inbox ---------------------------------------------------------------------------------
    def _on_reply(self, msg: MutexReply) -> None:
        if msg.granted:
            self._grants.append(msg.mutex)
            if self._waker is not None:
                self._waker(self._slot)

    def busy(self) -> bool:
        if self._grants:
            return True
        if (
            self.sleeps_while_waiting
            and self._held is not None
            and self.state == ACTIVE
            and self._standing is not None
            and self._bid_tick == self.tick
        ):
            # Waiting for an arm with a held level and a standing bid: the next loop would
            # re-apply the level, find no grant, bid the same and publish nothing — asleep until
            # a grant, an activation message or a sensing change wakes it.
            return False
        return super().busy()

    def update(self, tick: int, now: float) -> None:
        if self._done_by is not None and self.state != DONE:
            self.tick, self.now = tick, now
            self._finish_elsewhere()
            return
        super().update(tick, now)
        if self._standing is not None and self._bid_tick != tick:
            self._withdraw()  # would not have bid this loop: the standing bid ends

    # -- sharing with other robots ---------------------------------------------------------------
    def done_elsewhere(self, robot: str) -> None:
        """Another robot completed this behaviour: become done at the next loop (never run)."""
        if self.state != DONE and self._done_by is None:
            self._done_by = robot
            self.wake()

    def _finish_elsewhere(self) -> None:
        self._withdraw()
        for arm in self._grants:
            self._release_arm(arm)
        self._grants.clear()
        self.arm = None
        self.progress = True
        self.set_state(DONE, by=self._done_by)
        self.emit("done_elsewhere", by=self._done_by)
        self.publish_state()

    def _withdraw(self) -> None:
        standing = self._standing
        if standing is None:
            return
        self._standing = None
        publish = self._transport.publish
        for arm, topic in self._requests:
            if arm in standing:
                publish(topic, self._withdraw_msg)

    def _release_arm(self, arm: str) -> None:
        self._transport.publish(release_topic(arm), self._release)

    def _release_stray_grants(self) -> None:
        for arm in self._grants:
            if arm != self.arm:
                self._release_arm(arm)
        self._grants.clear()

    # -- action interface (override these; PickAndPlace implements them) ----------------------
    def bid(self, arm: str) -> float:
        """Activation potential of this behaviour on ``arm`` (Algorithm 8); default 1.0."""
        return 1.0

    def current_bids(self) -> dict[str, float]:
        """The bid for each arm's mutex (the activation potential for that arm)."""
        for arm in self.arms:
            self.bids[arm] = self.bid(arm)
        return self.bids

    def update_potential(self) -> None:
        if self.state != RUNNING:  # a running node keeps its last bid
            self.potential = max(self.current_bids().values(), default=0.0)

    def ready(self) -> bool:
        """Non-mutex part of the preconditions (ObjectInView for PickAndPlace)."""
        return True

    def start_action(self, arm: str) -> dict[str, object]:
        """Start on ``arm`` (its mutex is held); the dictionary goes into the ``start`` log
        event (``duration`` is shown in the trace)."""
        return {}

    def step_action(self) -> str:
        """``"running"``, ``"done"`` or ``"invalid"`` (validity check failed)."""
        return "done"

    def abort_action(self) -> dict[str, object]:
        """Stop after ``"invalid"``; the dictionary goes into the ``reset`` log event."""
        return {}

    # -- Algorithm 1 hooks ---------------------------------------------------------------------
    def preconditions(self) -> bool:  # Algorithm 9
        grants = self._grants
        gate = self.gate
        if not self.ready() or (gate is not None and gate.blocked(self.name)):
            self._release_stray_grants()
            return False
        if grants:
            bids = self.current_bids()
            best = max(grants, key=lambda a: (bids.get(a, 0.0), -self.arms.index(a)))
            if gate is not None:
                verdict = gate.permits(self.name)
                if verdict is None:  # the claim is on its way to the other robots: hold the arm
                    for arm in grants:
                        if arm != best:
                            self._release_arm(arm)
                    self._grants[:] = [best]
                    return False
                if not verdict:  # another robot has it (or a rival alternative): let the arm go
                    self.arm = None
                    self._release_stray_grants()
                    return False
            self.arm = best
            self._release_stray_grants()
            return True
        publish = self._transport.publish
        bids = self.current_bids()
        self._bid_tick = self.tick
        if self._latched:
            standing = self._standing
            if standing is None:
                standing = self._standing = {}
            for arm, topic in self._requests:
                bid = bids[arm]
                if standing.get(arm) != bid:
                    standing[arm] = bid
                    publish(topic, MutexRequest(self.name, bid, True))
            return False
        for arm, topic in self._requests:
            publish(topic, MutexRequest(self.name, bids[arm]))
        return False

    def activate(self) -> None:
        arm = self.arm
        assert arm is not None
        info = self.start_action(arm)
        self.progress = True
        self.set_state(RUNNING, arm=arm)
        self.emit("start", arm=arm, **info)

    def run(self) -> None:
        self._release_stray_grants()
        status = self.step_action()
        if status == "running":
            return
        arm = self.arm
        assert arm is not None
        if status == "done":
            self.set_state(DONE, arm=arm)
            self.emit("done", arm=arm)
            if self.gate is not None:
                self.gate.finished(self.name)
        else:
            if self.gate is not None:
                self.gate.released(self.name)
            info = self.abort_action()
            self.resets += 1
            self.progress = False
            self.set_state(ACTIVE if self.level > self._tau else INACTIVE, arm=arm, reset=True)
            self.emit("reset", arm=arm, **info)
        self._release_arm(arm)
        self.arm = None

    def deactivated(self) -> None:
        if self._grants:  # a grant that came too late goes back at once
            self._release_stray_grants()

    idle_done = deactivated

    def snapshot(self) -> dict[str, object]:
        snap = super().snapshot()
        snap.update(arm=self.arm, resets=self.resets, bids=dict(self.bids))
        return snap


class MotionBehavior(BehaviorNode):
    """A behaviour that moves an arm through a :class:`~flexhrc.behavior.world.PickAndPlaceMotion`
    of its world: :meth:`start_action` (a subclass's) sets ``self._motion``, and ``self._check``
    when validity checking watches an object — until the grasp (or the dwell) is over; then
    :meth:`step_action` and :meth:`abort_action` are the same for every such behaviour."""

    def __init__(
        self,
        name: str,
        world: TabletopWorld,
        transport: Transport,
        params: NetworkParams,
        obj: str | None = None,
    ) -> None:
        super().__init__(name, world.arm_names, transport, params, obj)
        self._world = world
        self._motion: PickAndPlaceMotion | None = None
        self._check: ValidityCheck | None = None

    def step_action(self) -> str:
        motion = self._motion
        assert motion is not None
        check = self._check
        if not motion.grasped(self.now) and check is not None and not check.valid(self._world):
            return "invalid"
        return "done" if self.now >= motion.t_end else "running"

    def abort_action(self) -> dict[str, object]:
        assert self._motion is not None
        moved = self._check.displacement(self._world) if self._check is not None else 0.0
        self._world.abort(self._motion.arm, self.now)
        self._motion = None
        self._check = None
        return {"object": self.object, "reason": "object moved", "moved": round(moved, 4)}


class PickAndPlace(MotionBehavior):
    """Pick an object from the table and place it at its target (Algorithms 8–9)."""

    kind = "BEHAVIOR"
    sleeps_while_waiting = True

    def __init__(
        self,
        name: str,
        obj: str,
        world: TabletopWorld,
        transport: Transport,
        params: NetworkParams,
    ) -> None:
        super().__init__(name, world, transport, params, obj)
        self.object: str = obj
        self._index = world.object_index(obj)
        self._version = -1
        self._threshold = params.validity_threshold

    def update(self, tick: int, now: float) -> None:
        # Fast path, exactly equivalent to Algorithm 1 for an idle behaviour: inactive, below τ,
        # no grant to hand back, nothing new sensed (so nothing to publish either).
        if self._held is not None:
            self.level = self._held
        world = self._world
        seen = self._version
        if (
            self.state == INACTIVE
            and self.level <= self._tau
            and not self._grants
            and seen >= world.sensing_stamps[self._index]
            and seen >= world.sensing_stamp_all
            and self._last_published is not None
            and self._standing is None
            and self._done_by is None
        ):
            self.tick = tick
            self.now = now
            self.level *= self._alpha
            return
        super().update(tick, now)

    def update_potential(self) -> None:  # Algorithm 8: 1 / ||x_obj - x_arm||
        world = self._world
        seen = self._version
        if self.state == RUNNING or (
            seen >= world.sensing_stamps[self._index] and seen >= world.sensing_stamp_all
        ):
            return  # nothing new sensed for this object; a running node keeps its last bid
        self._version = world.sensing_version
        self.potential = world.potentials()[0][self._index]

    def current_bids(self) -> dict[str, float]:
        per_arm = self._world.potentials()[1]
        i = self._index
        for k, arm in enumerate(self.arms):
            self.bids[arm] = per_arm[k][i]
        return self.bids

    def ready(self) -> bool:
        return self._world.object_in_view(self.object)

    def start_action(self, arm: str) -> dict[str, object]:
        self._motion = self._world.start_pick_and_place(arm, self.object, self.now)
        self._check = ValidityCheck.watch(self._world, self.object, self._threshold)
        return {"object": self.object, "duration": round(self._motion.duration, 3)}

    def abort_action(self) -> dict[str, object]:
        self._version = -1  # where the arm stopped is sensed anew
        return super().abort_action()
