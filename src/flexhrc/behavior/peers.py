"""Several robots, one task: a network per robot, progress and claims shared by peer messages.

Fraser et al.'s follow-up (Blankenburg et al., 2017) runs one behaviour network per robot (a PR2
and a Baxter) on one task. Here each robot runs its own full copy of the network on its own
arms; a :class:`PeerLink` per robot connects the copies over a
:class:`~flexhrc.transport.Transport` (the in-process bus, or Zenoh between processes) so that
no sub-goal is done twice and every constraint holds:

* **claims** — a behaviour that has won one of its robot's arms asks the other robots before it
  starts (:class:`PeerClaim`). A robot refuses (:class:`PeerReply`) when the behaviour *conflicts*
  with one it has completed, is running, or is itself claiming with priority (the smaller robot
  name wins a tie); two behaviours conflict when they are the same or lie in different
  alternatives of one OR. Otherwise it grants, and keeps the behaviour — and every rival OR
  alternative — blocked while the claim stands. Only once every live robot has granted does the
  behaviour start; a refusal releases the arm at once;
* **progress** — a completed behaviour is announced (:class:`PeerDone`): the others mark their
  copy done without running it (it reports *done* to its parent like a local one, so THEN
  sequences advance and ORs close) and move its object to its target in their world model;
  a reset releases the claim (:class:`PeerRelease`);
* **failures** — when a robot is lost (its process died: a Zenoh liveliness token disappears,
  :meth:`PeerLink.peer_lost`), its claims are dropped and its unfinished behaviours become free:
  the others finish the task. A claim waits only for robots still alive.

Every robot sends on its own topic ``bnpeer/<robot>``, so one robot's messages arrive in order.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any, NamedTuple

from flexhrc.behavior import messages
from flexhrc.behavior.behaviors import BehaviorNode
from flexhrc.behavior.network import BehaviorNetwork, Run, RunResult
from flexhrc.behavior.params import NetworkParams
from flexhrc.behavior.task import BEHAVIOR, OR, Task
from flexhrc.behavior.world import Arm, TabletopWorld, default_arms
from flexhrc.errors import FlexhrcError
from flexhrc.transport.base import Subscription, Transport
from flexhrc.transport.inprocess import InProcessBus


class PeerClaim(NamedTuple):
    robot: str
    behavior: str
    seq: int


class PeerReply(NamedTuple):
    robot: str
    to: str
    behavior: str
    seq: int
    granted: bool


class PeerDone(NamedTuple):
    robot: str
    behavior: str


class PeerRelease(NamedTuple):
    robot: str
    behavior: str


PEER_MESSAGES = {c.__name__: c for c in (PeerClaim, PeerReply, PeerDone, PeerRelease)}


def peer_topic(robot: str) -> str:
    return f"bnpeer/{robot}"


def from_wire(data: Any) -> Any:
    """A peer message from its JSON form; ``ValueError`` for anything else."""
    return messages.from_wire(data, PEER_MESSAGES)


@dataclass
class _Claim:
    seq: int
    waiting: set[str]
    refused: bool = False

    @property
    def granted(self) -> bool:
        return not self.refused and not self.waiting


class PeerLink:
    """Connects one robot's network to the other robots' (see the module docstring)."""

    def __init__(
        self,
        robot: str,
        peers: Iterable[str],
        transport: Transport,
        network: BehaviorNetwork,
    ) -> None:
        self.robot = robot
        self.peers = sorted(set(peers) - {robot})
        self.alive = set(self.peers)
        self.transport = transport
        self.network = network
        self._topic = peer_topic(robot)
        # per behaviour: the OR ancestors on its path, with the index of the child it is under
        self._or_path = _or_paths(network.task)
        self._mine: dict[str, _Claim] = {}
        self._seq = 0
        self._remote_claims: dict[str, str] = {}  # behaviour -> robot holding it
        self._remote_done: set[str] = set()
        self._fixed: dict[str, int] = {}  # OR -> the alternative something completed in
        self._claimed_or: dict[str, dict[int, int]] = {}  # OR -> alternative -> remote claims
        self._waiters: set[str] = set()
        #: (robot, behaviour) of every completion announced by another robot, in arrival order.
        self.remote_done: list[tuple[str, str]] = []
        self._subs: list[Subscription] = [
            transport.subscribe(peer_topic(p), self._on_message) for p in self.peers
        ]
        for node in network.nodes.values():
            if isinstance(node, BehaviorNode):
                node.gate = self

    # -- the gate a behaviour asks ---------------------------------------------------------
    def blocked(self, behavior: str) -> bool:
        if behavior in self._remote_done or behavior in self._remote_claims:
            self._waiters.add(behavior)
            return True
        for o, i in self._or_path.get(behavior, ()):
            fixed = self._fixed.get(o)
            if (fixed is not None and fixed != i) or any(
                j != i and n > 0 for j, n in self._claimed_or.get(o, {}).items()
            ):
                self._waiters.add(behavior)
                return True
        return False

    def permits(self, behavior: str) -> bool | None:
        claim = self._mine.get(behavior)
        if claim is None:
            self._seq += 1
            claim = _Claim(self._seq, set(self.alive))
            self._mine[behavior] = claim
            if claim.waiting:
                self._send(PeerClaim(self.robot, behavior, claim.seq))
        if claim.refused:
            del self._mine[behavior]
            self._send(PeerRelease(self.robot, behavior))
            self._waiters.add(behavior)
            return False
        if claim.granted:
            return True
        self._waiters.add(behavior)
        return None

    def finished(self, behavior: str) -> None:
        self._mine.pop(behavior, None)
        self._fix(behavior)
        self._send(PeerDone(self.robot, behavior))

    def released(self, behavior: str) -> None:
        if self._mine.pop(behavior, None) is not None:
            self._send(PeerRelease(self.robot, behavior))

    # -- robots coming and going -----------------------------------------------------------
    def peer_lost(self, robot: str) -> None:
        """``robot`` is gone (its process died): drop its claims, stop waiting for it."""
        if robot not in self.alive:
            return
        self.alive.discard(robot)
        for claim in self._mine.values():
            claim.waiting.discard(robot)
        for behavior, holder in list(self._remote_claims.items()):
            if holder == robot:
                self._drop_remote(behavior)
        self._wake_all()

    # -- messages --------------------------------------------------------------------------
    def _send(self, msg: NamedTuple) -> None:
        self.transport.publish(self._topic, msg)

    def _on_message(self, msg: Any) -> None:
        if msg.robot not in self.alive:
            return  # a robot declared lost stays lost for this run
        if isinstance(msg, PeerClaim):
            self._on_claim(msg)
        elif isinstance(msg, PeerReply):
            if msg.to != self.robot:
                return
            claim = self._mine.get(msg.behavior)
            if claim is None or claim.seq != msg.seq:
                return
            if msg.granted:
                claim.waiting.discard(msg.robot)
            else:
                claim.refused = True
            self._wake(msg.behavior)
        elif isinstance(msg, PeerDone):
            self._on_done(msg)
        elif isinstance(msg, PeerRelease) and self._remote_claims.get(msg.behavior) == msg.robot:
            self._drop_remote(msg.behavior)
            self._wake_all()

    def _on_claim(self, msg: PeerClaim) -> None:
        b = msg.behavior
        refuse = self._completed_conflict(b)
        if not refuse:
            for mine, claim in self._mine.items():
                if self._conflict(b, mine) and (claim.granted or self.robot < msg.robot):
                    refuse = True
                    break
        if not refuse:
            self._add_remote(b, msg.robot)
            self._wake_all()
        self._send(PeerReply(self.robot, msg.robot, b, msg.seq, not refuse))

    def _on_done(self, msg: PeerDone) -> None:
        b = msg.behavior
        if b in self._remote_done:
            return
        self.remote_done.append((msg.robot, b))
        self._remote_done.add(b)
        if b in self._remote_claims:
            self._drop_remote(b)
        self._fix(b)
        node = self.network.nodes.get(b)
        if isinstance(node, BehaviorNode):
            node.done_elsewhere(msg.robot)
            obj = node.object
            world = self.network.world
            if obj is not None and world.has_object(obj):
                target = world.objects[obj].target
                if target is not None:
                    world.move_object(obj, target)  # where the other robot put it
        self._wake_all()

    # -- bookkeeping -----------------------------------------------------------------------
    def _conflict(self, a: str, b: str) -> bool:
        if a == b:
            return True
        pa = dict(self._or_path.get(a, ()))
        return any(o in pa and pa[o] != i for o, i in self._or_path.get(b, ()))

    def _completed_conflict(self, b: str) -> bool:
        node = self.network.nodes.get(b)
        if b in self._remote_done or (node is not None and node.state == "done"):
            return True
        return any(
            (fixed := self._fixed.get(o)) is not None and fixed != i
            for o, i in self._or_path.get(b, ())
        )

    def _fix(self, b: str) -> None:
        for o, i in self._or_path.get(b, ()):
            self._fixed.setdefault(o, i)

    def _add_remote(self, b: str, robot: str) -> None:
        self._remote_claims[b] = robot
        for o, i in self._or_path.get(b, ()):
            counts = self._claimed_or.setdefault(o, {})
            counts[i] = counts.get(i, 0) + 1

    def _drop_remote(self, b: str) -> None:
        self._remote_claims.pop(b, None)
        for o, i in self._or_path.get(b, ()):
            counts = self._claimed_or.get(o, {})
            if counts.get(i, 0) > 0:
                counts[i] -= 1

    def _wake(self, behavior: str) -> None:
        node = self.network.nodes.get(behavior)
        if node is not None:
            node.wake()

    def _wake_all(self) -> None:
        waiters, self._waiters = self._waiters, set()
        for b in waiters:
            self._wake(b)

    def close(self) -> None:
        for sub in self._subs:
            sub.cancel()


def _or_paths(task: Task) -> dict[str, tuple[tuple[str, int], ...]]:
    out: dict[str, tuple[tuple[str, int], ...]] = {}
    stack: list[tuple[Any, tuple[tuple[str, int], ...]]] = [(task.root, ())]
    while stack:
        node, path = stack.pop()
        if node.kind == BEHAVIOR:
            out[node.name] = path
            continue
        for i, child in enumerate(node.children):
            stack.append((child, (*path, (node.name, i)) if node.kind == OR else path))
    return out


# ----------------------------------------------------------------------------- a team, one process


def robot_names(count: int) -> list[str]:
    if not 1 <= count <= 4:
        raise FlexhrcError(f"--robots must be in 1..4, got {count}")
    return [f"robot{k + 1}" for k in range(count)]


def robot_world(world: TabletopWorld, index: int, robot: str) -> TabletopWorld:
    """Robot ``index``'s model of the shared table: the same objects (a copy), its own arm."""
    homes = [*(arm.home for arm in default_arms(2)), (0.15, 0.0, 0.95), (1.05, 0.0, 0.95)]
    speed = next(iter(world.arms.values())).speed
    return TabletopWorld(
        copy.deepcopy(list(world.objects.values())),
        [Arm(robot, homes[index], speed)],
        copy.deepcopy(world.moves),
        world.grasp_time,
        world.place_time,
    )


@dataclass
class TeamResult:
    """A shared task run by several robots: each robot's own result, and all runs together."""

    outcome: str  # "done" when every live robot's copy of the task is achieved, else "timeout"
    robots: dict[str, RunResult]
    lost: list[str]
    ticks: int
    time: float
    runs: list[Run] = field(default_factory=list)
    #: When each lost robot was lost (simulated seconds).
    lost_at: dict[str, float] = field(default_factory=dict)

    @property
    def order(self) -> list[str]:
        done = [r for r in self.runs if r.outcome == "done"]
        done.sort(key=lambda r: (r.end or 0.0, r.behavior))
        return [r.behavior for r in done]

    def to_dict(self) -> dict[str, Any]:
        return {
            "outcome": self.outcome,
            "order": self.order,
            "ticks": self.ticks,
            "time": self.time,
            "lost": list(self.lost),
            "lost_at": dict(self.lost_at),
            "robots": {
                name: {"outcome": r.outcome, "order": r.order, "resets": r.resets}
                for name, r in self.robots.items()
            },
            "runs": [r.to_dict() for r in self.runs],
        }


def run_team(
    task: Task,
    world: TabletopWorld,
    robots: int = 2,
    params: NetworkParams | None = None,
    *,
    lose: Mapping[str, Callable[[BehaviorNetwork], bool]] | None = None,
    max_ticks: int | None = None,
    behaviors: Mapping[str, Any] | None = None,
    on_network: Callable[[str, BehaviorNetwork], None] | None = None,
    on_tick: Callable[[int], None] | None = None,
) -> TeamResult:
    """Run ``task`` with ``robots`` robots in one process, on one in-process peer bus.

    Every tick each live robot's network ticks, then the peer bus delivers. ``lose`` maps a
    robot name to a condition on its network: when it holds, the robot dies on the spot (it stops
    ticking and the others are told it is lost, as a Zenoh liveliness token would).
    ``on_network(robot, network)`` is called once per robot before the run (to add listeners:
    a live trace, a streamed log); ``on_tick(tick)`` after every round (to pace it).
    """
    from flexhrc.behavior.network import default_max_ticks

    names = robot_names(robots)
    bus = InProcessBus()
    nets: dict[str, BehaviorNetwork] = {}
    links: dict[str, PeerLink] = {}
    for k, name in enumerate(names):
        net = BehaviorNetwork(task, robot_world(world, k, name), params, behaviors=behaviors)
        nets[name] = net
        links[name] = PeerLink(name, names, bus, net)
        if on_network is not None:
            on_network(name, net)
    alive = list(names)
    lost: list[str] = []
    lost_at: dict[str, float] = {}
    limit = max_ticks if max_ticks is not None else default_max_ticks(task)
    tick = 0
    while alive and tick < limit and not all(nets[n].finished for n in alive):
        for name in list(alive):
            if lose and name in lose and lose[name](nets[name]):
                alive.remove(name)
                lost.append(name)
                lost_at[name] = nets[name].clock.now()
                links[name].close()
                for other in alive:
                    links[other].peer_lost(name)
        for name in alive:
            nets[name].tick()
        bus.flush()
        tick += 1
        if on_tick is not None:
            on_tick(tick)
    results = {name: nets[name].result() for name in names}
    runs = [  # every robot's runs, the arm named robot/arm, in start order
        Run(r.behavior, f"{robot}/{r.arm}", r.start, r.end, r.outcome)
        for robot, result in results.items()
        for r in result.runs
    ]
    runs.sort(key=lambda r: (r.start, r.behavior))
    done = bool(alive) and all(nets[n].finished for n in alive)
    period = nets[names[0]].params.tick_period
    return TeamResult(
        "done" if done else "timeout",
        results,
        lost,
        tick,
        round(tick * period, 9),
        runs,
        lost_at,
    )
