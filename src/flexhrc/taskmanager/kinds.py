"""Action kinds: what an action *is* physically, as data, in one registry.

An action schema names its kind (``kind: transport`` in the domain; without it the kind is the
action's name). A kind is registered once, by name, and every layer looks it up instead of
branching on words (the factory of BehaviorTree.CPP; flexhrc's own ``register_behavior_type``):

* **timing** — how the analytic simulator (paper 000, V-A) times it, for a robot arm and for an
  operator, when the schema declares neither ``duration`` nor ``moves_to`` (declared figures
  always win: the analytic time is then the hand's travel to ``moves_to`` plus ``duration``);
* **motion** — the controller actions of :mod:`flexhrc.action` (each an objective hierarchy of
  the task-priority controller, paper eq. 1-3) the kinematic simulator integrates, in order,
  each aimed at one of the action's *targets*; a joint action of both arms runs the same steps
  on both, carrying with the two-arm relative-pose objective;
* **effect** — what it does to the world besides its facts; the default is the domain's
  declarative rule (``moves_to`` / ``carries`` / ``fixes``, :func:`declared_effect`);
* **phrase** and **colour** — the verb phrase the panel and the trace print, the timeline colour;
* **moves** / :attr:`ActionKind.moves_arm` — whether the agent moves at all and whether a robot
  arm follows a trajectory (what a ROS 2 trajectory or marker publisher needs), and to which
  target (:func:`action_targets`, :meth:`ActionKind.final_target`).

Targets. A kind aims at up to two roles: the ``object`` it handles and the ``place`` it goes
to. A schema names them with ``target: ?p`` (the kind's only role) or ``target: [?obj, ?to]``;
otherwise ``carries`` is the object and ``moves_to`` the place, and failing those the action's
first argument that is a knowledge-base object (not one of its agents) is the object and the
last, when there are two or more, the place — the table's words keep their meaning.

The built-ins (:data:`BUILTIN_KINDS`) are registered below through :func:`register_action_kind`,
the call a user makes for a kind of their own. An action whose kind is not registered gets
:data:`DEFAULT_KIND`: no motion model (the analytic time), the declarative effect.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, Literal

from flexhrc.errors import FlexhrcError, UnknownNameError
from flexhrc.taskmanager.domain import set_kind_check

if TYPE_CHECKING:
    from flexhrc.knowledge import KnowledgeBase
    from flexhrc.taskmanager.domain import ActionSchema, Agent, Domain, GroundAction

Vec3 = tuple[float, float, float]
Role = Literal["object", "place"]
#: (success, seconds, reason of a failure) — what a timing model answers for one agent
StepTime = tuple[bool, float, str | None]


@dataclass
class Timing:
    """Nominal speeds (m/s) and fixed durations (s). Robot figures follow the paper's robot
    (max linear end-effector speed 0.4 m/s); human ones are typical assembly motions.

    ``robot_action_overhead`` / ``human_action_overhead`` are seconds added to every robot
    action that moves and to every operator action, by the analytic and the kinematic
    simulator alike; ``joint_speed_limit`` (rad/s) caps the robot model's joint velocity limits
    in the kinematic simulator (None: the model's own). All three are zero / None by default;
    :data:`TIMINGS` names the profiles (``default``, ``paper``)."""

    robot_speed: float = 0.4
    approach_overhead: float = 0.5
    transport_overhead: float = 0.5
    grasp: float = 1.0
    ungrasp: float = 0.8
    robot_screw: float = 4.0
    human_speed: float = 1.0
    human_pick_up: float = 1.0
    human_put_down: float = 1.5
    human_screw: float = 6.0
    place_tabletop: float = 6.0
    insert: float = 2.0
    reorient: float = 2.0
    robot_action_overhead: float = 0.0
    human_action_overhead: float = 0.0
    joint_speed_limit: float | None = None


#: The paper's Baxter and operator (000, §VII-C and Table I). The speeds are the paper's: end
#: effector at most 0.4 m/s and 0.8 rad/s (already the controller's and :class:`Timing`'s),
#: joints at most 0.6 rad/s. The paper gives no time per action, only Table I's averages over
#: eight 4-leg assemblies (robot actions 219.45 s, human actions 25.82 s, total 250.09 s), so
#: the rest is calibrated on them: every robot action that moves spends 5.0 s besides its
#: motion (the "update workspace" perception step the paper lists among the robot actions,
#: gripper and settling time of a real Baxter), every operator action 4.1 s more than the
#: default operator (reaching, handling, a look). With these the default ``demo table`` (4 legs,
#: passive operator, seed 0, kinematic simulator) simulates 220 s of robot and 26 s of human
#: actions; the figures to set beside the paper's are those totals, the compute share and the
#: makespan, not the time of any single action. (Recalibrated in issue 21 as the hold became a
#: controller behaviour, then as the tabletop placement became Fig. 8 in full: its robot
#: actions, not one, are part of the paper's total.)
PAPER_TIMING = Timing(robot_action_overhead=5.0, human_action_overhead=4.1, joint_speed_limit=0.6)

#: Timing profiles by name: what ``--timing`` and a scenario's ``timing:`` key choose.
TIMINGS: dict[str, Timing] = {"default": Timing(), "paper": PAPER_TIMING}


def timing_profile(name: str) -> Timing:
    """A copy of the timing profile ``name`` (one of :data:`TIMINGS`)."""
    if name not in TIMINGS:
        raise FlexhrcError(f"unknown timing {name!r}; choose one of {', '.join(TIMINGS)}")
    return replace(TIMINGS[name])


@dataclass(slots=True)
class StepContext:
    """One agent's share of an action in the analytic simulator: what a timing model reads.

    ``positions`` are where things are in this simulation (updated in place: a model that moves
    the hand or the object writes it here); the knowledge base is never modified.
    """

    action: GroundAction
    agent: Agent
    positions: dict[str, Vec3]
    kb: KnowledgeBase
    timing: Timing

    def pos(self, name: str) -> Vec3:
        return self.positions.get(name) or self.kb.position(name)

    @property
    def targets(self) -> tuple[str | None, str | None]:
        """(object, place) of the action (see the module docstring)."""
        return action_targets(self.action, self.kb)

    @property
    def params(self) -> Mapping[str, Any]:
        return self.agent.params

    @property
    def speed(self) -> float:
        default = self.timing.human_speed if self.agent.is_human else self.timing.robot_speed
        return float(self.params.get("speed", default))

    @property
    def base(self) -> Vec3:
        return _v(self.params.get("base", (0.0, 0.0, 0.0)))

    @property
    def rest(self) -> Vec3:
        return _v(self.params.get("rest", self.base))

    @property
    def hand(self) -> Vec3:
        """Where the agent's hand (an arm's end effector) is now."""
        name = self.agent.name
        if name in self.positions:
            return self.positions[name]
        if name in self.kb.objects:
            return self.kb.position(name)
        return (1.0, 0.0, 0.1) if self.agent.is_human else self.rest

    def unreachable(self, p: Vec3, what: str) -> str | None:
        """Why the arm cannot reach ``p`` (``reachable_by`` of the object, the reach sphere
        around ``base``), or None."""
        arm = self.agent.name
        rec = self.kb.objects.get(what)
        allowed = rec.attrs.get("reachable_by") if rec is not None else None
        if allowed is not None and arm not in allowed:
            return f"{what} cannot be reached by {arm} (blocked)"
        reach = float(self.agent.params.get("reach", 0.85))
        d = math.dist(self.base, p)
        if d > reach:
            return f"{what} at {_fmt(p)} is out of reach of {arm} ({d:.2f} m > {reach:.2f} m)"
        return None


TimingModel = Callable[[StepContext], StepTime]
Effect = Callable[["KnowledgeBase", "Domain", "GroundAction", Mapping[str, Any]], "str | None"]


@dataclass(frozen=True)
class MotionStep:
    """One controller action of a kind's motion: ``action`` names an action definition of the
    kinematic simulator (:data:`flexhrc.action.simulator.ACTIONS`: ``approach``, ``grasp``,
    ``transport``, ``insert``, ``screw``, ``ungrasp``, ``rest``, ...); ``target`` the roles it may
    aim at, in order of preference (none: where the hand is); ``height`` which offset above the
    target the hand keeps (``grasp``: where it grasps, ``hold``: where it holds a part over a
    place). A step whose target does not resolve is aimed at the hand's current pose when
    ``optional``, else the action is left to the analytic model."""

    action: str
    target: tuple[Role, ...] = ()
    height: Literal["grasp", "hold"] = "grasp"
    optional: bool = False


@dataclass(frozen=True)
class ActionKind:
    """What one kind of action is; see the module docstring. Register with
    :func:`register_action_kind`."""

    name: str
    phrase: str = "{action}"
    robot_time: TimingModel | None = None  # None: 1 s per arm
    human_time: TimingModel | None = None  # None: 2 s
    fallible: bool = True  # the analytic simulator's seeded faults may hit it
    motion: tuple[MotionStep, ...] = ()
    moves: bool = True  # False: the agent does not move (a look, a wait): simulated 'none'
    carries_object: bool = False  # in a simulation the object ends at the place
    aims_at: tuple[Role, ...] = ()  # the roles a one-parameter ``target:`` names, in order
    effect: Effect | None = None  # None: the declarative rule (declared_effect)
    colour: str | None = None  # None: the timeline picks one from its palette
    aliases: tuple[str, ...] = field(default=(), compare=False)

    @property
    def moves_arm(self) -> bool:
        """A robot arm follows a trajectory for it (the kinematic simulator, ROS 2)."""
        return bool(self.motion)

    def describe(self, action: GroundAction, kb: KnowledgeBase | None = None) -> str:
        """The verb phrase of ``action`` for the panel and the trace (``carry leg1 to
        bolt_1``)."""
        obj, place = action_targets(action, kb)
        try:
            return self.phrase.format(
                action=str(action), object=obj or "it", place=place or "its place",
                name=action.name,
            )  # fmt: skip
        except (KeyError, IndexError, ValueError):
            return str(action)

    def final_target(self, action: GroundAction, kb: KnowledgeBase) -> str | None:
        """The knowledge-base object the arm ends at (None: it stays where it is, or has no
        motion) — for a trajectory's or a marker's goal."""
        obj, place = action_targets(action, kb)
        found = None
        for step in self.motion:  # the last step that aims somewhere: its first role known
            names = (obj if role == "object" else place for role in step.target)
            found = next((n for n in names if n is not None), found)
        return found


_KINDS: dict[str, ActionKind] = {}
_ALIASES: dict[str, str] = {}
_UNREGISTERED: dict[str, ActionKind] = {}  # DEFAULT_KIND under a name (made once per name)


def register_action_kind(
    name: str,
    *,
    phrase: str = "{action}",
    robot_time: TimingModel | float | None = None,
    human_time: TimingModel | float | None = None,
    fallible: bool = True,
    motion: tuple[MotionStep, ...] | list[MotionStep] = (),
    moves: bool = True,
    carries_object: bool = False,
    aims_at: tuple[Role, ...] = (),
    effect: Effect | None = None,
    colour: str | None = None,
    aliases: tuple[str, ...] | list[str] = (),
) -> ActionKind:
    """Make ``name`` usable as ``kind:`` in a domain (replaces an earlier registration).

    ``robot_time`` / ``human_time`` are timing models (a number: that many seconds);
    ``aliases`` are other names for the same kind (the table's ``ungrasp`` is ``release``).
    Returns the registered :class:`ActionKind`.
    """
    for n in (name, *aliases):
        if not n or not n.replace("_", "").isalnum():
            raise FlexhrcError(f"action kind name {n!r}: use letters, digits and '_'")
    for role in (*aims_at, *(r for s in motion for r in s.target)):
        if role not in ("object", "place"):
            raise FlexhrcError(f"action kind {name!r}: unknown target role {role!r}")
    kind = ActionKind(
        name, phrase, _model(robot_time), _model(human_time), fallible, tuple(motion), moves,
        carries_object, aims_at, effect, colour, tuple(aliases),
    )  # fmt: skip
    _KINDS[name] = kind
    _UNREGISTERED.clear()
    _ALIASES.pop(name, None)
    for alias in aliases:
        _ALIASES[alias] = name
    return kind


def action_kinds() -> list[str]:
    """The registered kind names and aliases, sorted."""
    return sorted({*_KINDS, *_ALIASES})


def action_kind(name: str) -> ActionKind:
    """The registered kind ``name`` (or the kind it is an alias of)."""
    found = find_action_kind(name)
    if found is None:
        raise UnknownNameError(f"unknown action kind {name!r} (known: {', '.join(action_kinds())})")
    return found


def find_action_kind(name: str) -> ActionKind | None:
    """The registered kind ``name``, or None."""
    kind = _KINDS.get(name)
    if kind is None and name in _ALIASES:
        kind = _KINDS.get(_ALIASES[name])
    return kind


def unknown_kind(name: str) -> str | None:
    """Why ``name`` cannot be a domain's ``kind:`` (None: it can)."""
    if find_action_kind(name) is not None:
        return None
    return (
        f"unknown kind {name!r} (kinds: {', '.join(action_kinds())}; register your own with "
        "flexhrc.taskmanager.kinds.register_action_kind)"
    )


def kind_of(schema: ActionSchema) -> ActionKind:
    """The kind of an action schema: its registered kind, else :data:`DEFAULT_KIND` (under the
    schema's own kind name)."""
    name = schema.kind or schema.name
    found = find_action_kind(name) or _UNREGISTERED.get(name)
    if found is None:
        found = _UNREGISTERED[name] = replace(DEFAULT_KIND, name=name)
    return found


def describe_action(action: GroundAction, kb: KnowledgeBase | None = None) -> str:
    """The verb phrase of ``action``'s kind, for the panel and the trace (``grasp leg1``)."""
    return kind_of(action.schema).describe(action, kb)


def action_targets(
    action: GroundAction, kb: KnowledgeBase | None = None
) -> tuple[str | None, str | None]:
    """(object, place) of a ground action (see the module docstring); without ``kb`` every
    argument that is not one of the action's agents counts as an object."""
    schema = action.schema
    if schema.target:
        names = [action.binding.get(v) for v in schema.target]
        if len(names) >= 2:
            return names[0], names[-1]
        roles = kind_of(schema).aims_at or ("object",)
        return (names[0], None) if roles[0] == "object" else (None, names[0])
    agents = action.agents
    if kb is None:
        objs = [a for a in action.args if a not in agents]
    else:
        objects = kb.objects
        objs = [a for a in action.args if a in objects and a not in agents]
    obj = place = None
    if schema.carries or schema.moves_to:  # a binding only when a role is declared (hot path)
        binding = action.binding
        obj = binding.get(schema.carries) if schema.carries else None
        place = binding.get(schema.moves_to) if schema.moves_to else None
    if obj is None and objs:
        obj = objs[0]
    if place is None and len(objs) >= 2:
        place = objs[-1]
    return obj, place


# -- the physical effect --------------------------------------------------------------------


def declared_effect(
    kb: KnowledgeBase, domain: Domain, action: GroundAction, positions: Mapping[str, Any]
) -> str | None:
    """The domain's declarative rule: an operator's hand goes where the report says; the
    ``carries`` object goes to the ``moves_to`` place (or with the hand) unless it is fixed;
    the ``fixes`` object is fixed in place (returned)."""
    schema, binding = action.schema, action.binding
    where = None
    if schema.moves_to and binding.get(schema.moves_to) in kb.objects:
        where = kb.position(binding[schema.moves_to])
    for agent in action.agents:
        if agent in positions and agent in kb.objects and domain.agent(agent).is_human:
            kb.move(agent, positions[agent])
    carried = binding.get(schema.carries) if schema.carries else None
    if carried in kb.objects and not kb.object(carried).fixed:
        hand = positions.get(action.agents[0]) if action.agents else None
        if hand is None and action.agents and action.agents[0] in kb.objects:
            hand = kb.position(action.agents[0])
        target = where or hand
        if target is not None:
            kb.move(carried, target)
    fixed = binding.get(schema.fixes) if schema.fixes else None
    if fixed in kb.objects:
        kb.set_fixed(fixed)
        return str(fixed)
    return None


# -- timing models of the built-ins (the analytic simulator's figures) ----------------------


def _model(value: TimingModel | float | None) -> TimingModel | None:
    if value is None or callable(value):
        return value
    seconds = float(value)
    if not 0.0 <= seconds < 1e6:
        raise FlexhrcError(f"a kind's time must be seconds in [0, 1e6), got {value!r}")
    return lambda _: (True, seconds, None)


def _go(ctx: StepContext, role: Role, what: str, overhead: float) -> StepTime:
    """The arm travels to the ``role`` target at its speed (reach checked), plus
    ``overhead``; the object role is its own position when the action names none."""
    obj, place = ctx.targets
    name = obj if role == "object" else place
    hand = ctx.hand
    if role == "place" and name is None:
        return False, 0.0, f"{ctx.action}: no destination"
    p = ctx.pos(name) if name else hand
    why = ctx.unreachable(p, name or what)
    if why:
        return False, 0.0, why
    ctx.positions[ctx.agent.name] = p
    if role == "place" and obj:
        ctx.positions[obj] = p
    return True, math.dist(hand, p) / ctx.speed + overhead, None


def _approach(ctx: StepContext) -> StepTime:
    return _go(ctx, "object", "target", ctx.timing.approach_overhead)


def _transport(ctx: StepContext) -> StepTime:
    return _go(ctx, "place", "place", ctx.timing.transport_overhead)


def _timed(seconds: Callable[[Timing], float]) -> TimingModel:
    """A time of the profile's (``seconds`` of the :class:`Timing`), wherever the hand is."""
    return lambda ctx: (True, seconds(ctx.timing), None)


_release = _timed(lambda t: t.ungrasp)


def _then(first: TimingModel, seconds: Callable[[Timing], float]) -> TimingModel:
    def model(ctx: StepContext) -> StepTime:
        ok, dt, why = first(ctx)
        return (ok, dt + seconds(ctx.timing), why) if ok else (ok, dt, why)

    return model


def _robot_screw(ctx: StepContext) -> StepTime:
    _, place = ctx.targets
    objs = [a for a in ctx.action.args if a in ctx.kb.objects and a != ctx.agent.name]
    where = place or (objs[-1] if objs else None)
    p = ctx.pos(where) if where else ctx.hand
    why = ctx.unreachable(p, where or "screw point")
    if why:
        return False, 0.0, why
    return True, ctx.timing.robot_screw, None


def _rest(ctx: StepContext) -> StepTime:
    d = math.dist(ctx.hand, ctx.rest)
    ctx.positions[ctx.agent.name] = ctx.rest
    return True, d / ctx.speed, None


def _human_pick_up(ctx: StepContext) -> StepTime:
    name = ctx.agent.name
    obj = next((a for a in ctx.action.args if a in ctx.kb.objects and a != name), None)
    hand = ctx.hand
    p = ctx.pos(obj) if obj else hand
    ctx.positions[name] = p
    return True, ctx.timing.human_pick_up + math.dist(hand, p) / ctx.timing.human_speed, None


def _human_screw(ctx: StepContext) -> StepTime:
    """The operator carries the part to its place at their speed and screws it there: the hand
    and the part end at the place. Left where the part was picked up, the hand would stand
    beside the parts still on the table and keep the arms away from them (the kinematic
    simulator keeps 15 cm from a human hand), and the fixed part would lie off its bolt."""
    obj, place = ctx.targets
    if place is None:
        return True, ctx.timing.human_screw, None
    hand, p = ctx.hand, ctx.pos(place)
    ctx.positions[ctx.agent.name] = p
    if obj:
        ctx.positions[obj] = p
    return True, math.dist(hand, p) / ctx.speed + ctx.timing.human_screw, None


def _v(p: object) -> Vec3:
    vals = [float(x) for x in p]  # type: ignore[attr-defined]
    return (vals[0], vals[1], vals[2])


def _fmt(p: Vec3) -> str:
    return "(" + ", ".join(f"{v:.2f}" for v in p) + ")"


#: An action whose kind is not registered: no motion model, the declarative effect.
DEFAULT_KIND = ActionKind("default")

_OBJ: tuple[Role, ...] = ("object",)
_PLACE: tuple[Role, ...] = ("place",)
_TO_OBJECT = MotionStep("approach", _OBJ)
_GRASP = MotionStep("grasp", _OBJ, optional=True)
_RELEASE = MotionStep("ungrasp")

register_action_kind(
    "approach", phrase="approach {object}", robot_time=_approach, motion=[_TO_OBJECT],
    aims_at=_OBJ, colour="#9ecae1",
)  # fmt: skip
register_action_kind(
    "grasp", phrase="grasp {object}", robot_time=_timed(lambda t: t.grasp), motion=[_GRASP],
    aims_at=_OBJ, colour="#6baed6",
)  # fmt: skip
register_action_kind(
    "transport", phrase="carry {object} to {place}", robot_time=_transport,
    motion=[MotionStep("transport", _PLACE, "hold")], carries_object=True, aims_at=_PLACE,
    colour="#4292c6",
)  # fmt: skip
register_action_kind(
    "place", phrase="place {object} at {place}",
    robot_time=_then(_transport, lambda t: t.ungrasp),
    motion=[MotionStep("transport", _PLACE), _RELEASE], carries_object=True, aims_at=_PLACE,
    colour="#41ab5d",
)  # fmt: skip
register_action_kind(
    "insert", phrase="insert {object} into {place}",
    robot_time=_then(_transport, lambda t: t.insert),
    motion=[MotionStep("transport", _PLACE, "hold"), MotionStep("insert", _PLACE)],
    carries_object=True, aims_at=_PLACE, colour="#238b45",
)  # fmt: skip
register_action_kind(
    "screw", phrase="screw {object} at {place}", robot_time=_robot_screw,
    human_time=_human_screw, motion=[MotionStep("screw", _PLACE, "hold", optional=True)],
    aims_at=_PLACE, colour="#2171b5",
)  # fmt: skip
register_action_kind(
    "hold", phrase="hold {object}", aims_at=_OBJ, colour="#807dba",
    motion=[_TO_OBJECT, MotionStep("grasp", _OBJ), MotionStep("hold"), _RELEASE],
)  # fmt: skip
# the node process P(n) of paper eq. 5: the hands take the part and keep it at its pose with the
# controller (the ``hold`` behaviour of flexhrc.action.simulator: a push is undone) until it is
# back and still, then let go; the analytic model times it by the schema's ``duration``
register_action_kind(
    "release", phrase="release {object}", robot_time=_release, motion=[_RELEASE],
    colour="#c6dbef", aliases=("ungrasp",),
)  # fmt: skip
register_action_kind(
    "rest", phrase="go to rest", robot_time=_rest, motion=[MotionStep("rest")], colour="#dddddd"
)
register_action_kind("check", phrase="check {object}", moves=False, aims_at=_OBJ, colour="#fdd0a2")
register_action_kind("none", phrase="{name}", moves=False, colour="#f0f0f0")
# the table's words that are not the generic ones
register_action_kind(
    "place_tabletop", phrase="place {object} at {place} (both arms)",
    robot_time=_timed(lambda t: t.place_tabletop), fallible=False,
    motion=[
        _TO_OBJECT, MotionStep("grasp", _OBJ), MotionStep("transport", ("place", "object")),
        _RELEASE,
    ],
    carries_object=True, aims_at=_PLACE, colour="#08519c",
)  # fmt: skip
# Fig. 8 (d): the tabletop, held in both hands, turned flat on its way from the stand
register_action_kind(
    "reorient", phrase="turn {object} flat", robot_time=_timed(lambda t: t.reorient),
    motion=[MotionStep("reorient")], aims_at=_OBJ, colour="#3182bd",
)  # fmt: skip
register_action_kind(
    "pick_up", phrase="pick up {object}", robot_time=_then(_approach, lambda t: t.grasp),
    human_time=_human_pick_up, motion=[_TO_OBJECT, _GRASP], aims_at=_OBJ, colour="#fd8d3c",
)  # fmt: skip
register_action_kind(
    "put_down", phrase="put {object} down", robot_time=_release,
    human_time=_timed(lambda t: t.human_put_down), motion=[_RELEASE], colour="#fdae6b",
)  # fmt: skip

#: The kinds flexhrc ships (the generic set, then the table's own words; ``ungrasp`` is an
#: alias of ``release``).
BUILTIN_KINDS = (
    "approach", "grasp", "transport", "place", "insert", "screw", "hold", "release", "rest",
    "check", "none", "place_tabletop", "pick_up", "put_down", "ungrasp", "reorient",
)  # fmt: skip

__all__ = [
    "BUILTIN_KINDS",
    "DEFAULT_KIND",
    "ActionKind",
    "MotionStep",
    "StepContext",
    "action_kind",
    "action_kinds",
    "action_targets",
    "declared_effect",
    "describe_action",
    "find_action_kind",
    "kind_of",
    "register_action_kind",
    "unknown_kind",
]


set_kind_check(unknown_kind)  # Domain.from_dict refuses an unknown ``kind:`` by this registry
