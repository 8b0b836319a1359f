"""The kinematic simulator in the Task Manager's loop (paper 000, V-A: the in-the-loop simulator).

:class:`KinematicTaskSimulator` implements both sides the Task Manager needs:

* the :class:`~flexhrc.taskmanager.Simulator` protocol — a decision-tree branch's ground actions
  (``approach(left, leg2)``, ``transport(left, leg2, bolt_1)``, ...) are integrated with the
  task-priority controller on the robot model, from the robot's current configuration, in the
  world the knowledge base describes (objects, obstacles, the operator's hand). Success and
  durations — hence the utility of eq. (21) — come from the simulation: an arm that cannot reach
  a leg, or a bolt behind an obstacle, scores 0;
* the :class:`~flexhrc.taskmanager.ExecutionModel` protocol — commands run on the simulated
  "real" robot of an :class:`~flexhrc.action.ExecutionManager`, where disturbances can be
  injected (:meth:`inject`), so execution may differ from the prior simulation and fail.

Objects lie on the table at the positions of the knowledge base; the hand grasps a leg
``grasp_height_m`` above its position and holds it ``hold_height_m`` above a place (a bolt or the
middle pose) to transport and screw it. Human actions are timed by the analytic operator model.
Knowledge-base objects of type ``obstacle`` (attribute ``radius``) are spheres in both worlds.

Which motion an action is comes from its kind (:mod:`flexhrc.taskmanager.kinds`), not from its
name: each kind lists the controller actions to integrate and the target each aims at (the
object it handles, the place it goes to). Joint actions (``agents: {joint: [left, right]}``) run
the same steps on both arms at once (``arm="both"``): each hand grasps the object ``span_m / 2``
to its own side and, while the object is carried, the controller's two-arm relative-pose
objective keeps the grasp rigid (paper eq. 1-3 and Fig. 8). The table's tabletop placement is
a sequence of such joint commands (Fig. 8): ``pick_tabletop`` (approach, grasp),
``reorient_tabletop`` (the two-arm turn flat), ``place_tabletop`` (carry to the assembly pose,
let go), the node process ``hold(tabletop)`` and ``return_to_rest()``. Actions of a kind
without motion (``check``, ``none``), of a kind the registry has no motion for, of an agent the
robot model has no arm for, or whose target does not resolve are timed by the analytic model,
as the operator's actions are. :attr:`KinematicTaskSimulator.simulated` records how each
action was simulated.

The branches of one decision share their work (issue 23): :meth:`KinematicTaskSimulator.
simulate_many` advances them together, takes a motion the same arm already made from the same
joints in the same world from a cache (:func:`flexhrc.action.batch.motion_key`) and integrates
the rest side by side (:mod:`flexhrc.action.lockstep`); the results are those of
:meth:`~KinematicTaskSimulator.simulate` branch by branch.
"""

from __future__ import annotations

import time
from collections import OrderedDict
from collections.abc import Generator, Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from flexhrc.knowledge import KnowledgeBase
from flexhrc.taskmanager.domain import Domain, GroundAction
from flexhrc.taskmanager.kinds import Timing, action_targets, kind_of
from flexhrc.taskmanager.simulator import (
    AnalyticSimulator,
    SimulationResult,
    StepReport,
    Vec3,
    hand_paths,
    hands,
    simulated_record,
    step_detail,
)

if TYPE_CHECKING:  # pragma: no cover
    from flexhrc.action.batch import MotionRequest

Motion = list[tuple[str, "tuple[float, float, float] | None"]]


class KinematicTaskSimulator:
    """Task-Manager simulator and execution model backed by :mod:`flexhrc.action`.

    ``share`` (default): the branches of a decision share their motions
    (:meth:`simulate_many`, a motion cache of ``cache_size`` entries kept across decisions,
    lockstep integration); ``share=False`` integrates every motion of every branch on its own
    (the path before issue 23, kept to compare against).
    """

    def __init__(
        self,
        simulator: Any = None,
        *,
        execution: Any = None,
        human: AnalyticSimulator | None = None,
        grasp_height_m: float = 0.02,
        hold_height_m: float = 0.10,
        dt: float = 0.04,
        timing: Timing | None = None,
        share: bool = True,
        cache_size: int = 4096,
    ):
        from flexhrc.action.execution import ExecutionManager
        from flexhrc.action.simulator import KinematicSimulator

        # the timing profile: the robot model's joint speeds, the per-action overheads and the
        # operator's times (all of the default profile's are the model's own)
        self.timing = timing or (human.timing if human is not None else Timing())
        limit = self.timing.joint_speed_limit
        # a 40 ms step ranks branches as well as 20 ms (durations within ~3 %) at half the cost
        self.sim = (
            simulator
            if simulator is not None
            else KinematicSimulator(dt=dt, joint_speed_limit=limit)
        )
        self.execution = (
            execution
            if execution is not None
            else ExecutionManager(KinematicSimulator(joint_speed_limit=limit))
        )
        self.human = human or AnalyticSimulator(self.timing)
        self.grasp_height_m = grasp_height_m
        self.hold_height_m = hold_height_m
        self.wall_s = 0.0
        self._simulated: dict[tuple[str, tuple[str, ...]], str] = {}
        self._scheduled: list[list[Any]] = []  # [action kind, nth, disturbance kwargs, seen]
        #: branch simulations share their motions (False: each integrated as it comes, the
        #: path before issue 23, kept to compare against)
        self.share = share
        self.cache_size = int(cache_size)
        self._motion_cache: OrderedDict[Any, Any] = OrderedDict()
        self._far_cache: OrderedDict[Any, Any] = OrderedDict()
        #: motions taken from the hand-free cache (the hand moved, but stayed far)
        self.motions_far = 0
        #: controller actions branch simulations asked for, and how many were integrated
        #: (the rest came from the motion cache or a twin in the same round)
        self.motions_requested = 0
        self.motions_integrated = 0
        #: controller steps integrated for branch simulations (load-independent cost; an
        #: outcome the simulator's own cache returned counts its steps again)
        self.steps_integrated = 0

    @property
    def simulated(self) -> dict[str, str]:
        """How each ground action simulated or executed so far was, by its text:
        ``kinematic`` (on the robot model), ``analytic`` (timed by the analytic model) or
        ``none`` (a kind without motion)."""
        return simulated_record(self._simulated)

    # -- the arms' joints, as the cell protocol carries them ----------------------------------
    def joint_state(self, arms: Iterable[str]) -> dict[str, list[float]]:
        """Where ``arms`` are now (rad), those of the robot model among them."""
        q = self.execution.state.q
        return {a: [float(v) for v in q[a]] for a in arms if a in q}

    def set_joint_state(self, joints: Mapping[str, Sequence[float]]) -> None:
        """Put the model's arms where an agent or the manager says they are: over processes
        the manager's model and each arm's world are separate objects, and each plans from
        where the arms really are only if told (in one process they are one object)."""
        q = self.execution.state.q
        for arm, values in joints.items():
            if arm in q and len(values) == len(q[arm]):
                q[arm] = np.asarray(values, dtype=float)

    # -- geometry -------------------------------------------------------------------------
    def _pos(self, name: str, kb: KnowledgeBase, positions: dict[str, Vec3]) -> Vec3:
        return positions.get(name) or kb.position(name)

    def motions(
        self, action: GroundAction, kb: KnowledgeBase, positions: dict[str, Vec3]
    ) -> Motion | None:
        """The controller actions of ``action``'s kind, each with where the hand goes (None:
        where it is); None when the kind has no motion or a target it needs does not resolve."""
        kind = kind_of(action.schema)
        if not kind.motion:
            return None
        obj, place = action_targets(action, kb)
        out: Motion = []
        for step in kind.motion:
            goal = None
            for role in step.target:
                name = obj if role == "object" else place
                if name is not None and (name in positions or name in kb.objects):
                    x, y, z = self._pos(name, kb, positions)
                    lift = self.grasp_height_m if step.height == "grasp" else self.hold_height_m
                    goal = (x, y, z + lift)
                    break
            if goal is None and step.target and not step.optional:
                return None
            out.append((step.action, goal))
        return out

    def how(
        self,
        action: GroundAction,
        kb: KnowledgeBase,
        positions: dict[str, Vec3],
        domain: Domain,
    ) -> tuple[str, Motion | None]:
        """``(kinematic, motions)`` for an action simulated on the robot model, else
        ``(analytic | none, None)`` (see the module docstring); recorded in :attr:`simulated`."""
        kind = kind_of(action.schema)
        motions = None
        if not kind.moves:
            how = "none"
        elif any(domain.agent(a).is_human for a in action.agents) or not set(action.agents) <= set(
            self.sim.robot.arm_names
        ):
            how = "analytic"
        else:
            motions = self.motions(action, kb, positions)
            how = "analytic" if motions is None else "kinematic"
        self._simulated[action.name, action.args] = how
        return how, motions

    @staticmethod
    def obstacles(kb: KnowledgeBase) -> list[tuple[float, float, float, float]]:
        return [
            (*o.position, float(o.attrs.get("radius", o.size.get("radius", 0.05))))
            for o in kb.objects_of_type("obstacle")
        ]

    @staticmethod
    def human_hand(kb: KnowledgeBase) -> Vec3 | None:
        return kb.position("human") if "human" in kb.objects else None

    def _arm(self, action: GroundAction) -> str:
        """``left``/``right``, or ``both`` for a joint action of the robot's two arms."""
        if len(action.agents) == 1:
            return action.agents[0]
        return "both"

    def _check(self, action: GroundAction) -> str | None:
        arms = set(self.sim.robot.arm_names)
        if len(action.agents) == 1 or (
            set(action.agents) == arms and len(action.agents) == len(arms)
        ):
            return None
        return (
            f"{action}: a joint action needs the robot's arms "
            f"{' and '.join(sorted(arms))}, got {', '.join(action.agents)}"
        )

    # -- Simulator protocol ---------------------------------------------------------------
    def simulate(
        self, steps: Sequence[GroundAction], kb: KnowledgeBase, domain: Domain
    ) -> SimulationResult:
        t0 = time.perf_counter()
        try:
            return self._simulate(steps, kb, domain)
        finally:
            self.wall_s += time.perf_counter() - t0

    def simulate_many(
        self, branches: Sequence[Sequence[GroundAction]], kb: KnowledgeBase, domain: Domain
    ) -> list[SimulationResult]:
        """:meth:`simulate` for every branch of one decision, their motions shared.

        The branches advance together, one controller action each per round: the round's
        motions are looked up in the motion cache (the same arm, from the same joints, towards
        the same target in the same world is integrated once — whatever the other arm does,
        which a one-arm controller never reads) and the rest are integrated side by side by
        :func:`flexhrc.action.batch.simulate_many` (lockstep, vectorised over the branches).
        Results are those of :meth:`simulate` branch by branch (``share=False`` runs exactly
        that: the old path, for comparison). An analytic model with seeded failures draws its
        random numbers in branch order, so then the branches run one after another."""
        t0 = time.perf_counter()
        try:
            if not self.share or float(getattr(self.human, "failure_rate", 0.0) or 0.0) > 0:
                return [self._simulate(s, kb, domain) for s in branches]
            return self._simulate_many(branches, kb, domain)
        finally:
            self.wall_s += time.perf_counter() - t0

    def _simulate(
        self, steps: Sequence[GroundAction], kb: KnowledgeBase, domain: Domain
    ) -> SimulationResult:
        branch = self._branch(steps, kb, domain)
        try:
            request = next(branch)
            while True:
                request = branch.send(self._motion(request))
        except StopIteration as stop:
            result: SimulationResult = stop.value
            return result

    def _simulate_many(
        self, branches: Sequence[Sequence[GroundAction]], kb: KnowledgeBase, domain: Domain
    ) -> list[SimulationResult]:
        results: list[SimulationResult | None] = [None] * len(branches)
        live: dict[int, tuple[Generator[MotionRequest, Any, SimulationResult], MotionRequest]]
        live = {}
        before = dict(self._simulated)
        touched: list[list[tuple[str, tuple[str, ...]]]] = [[] for _ in branches]
        for i, steps in enumerate(branches):
            gen = self._branch(steps, kb, domain, touched[i])
            try:
                live[i] = (gen, next(gen))
            except StopIteration as stop:
                results[i] = stop.value
        while live:
            order = list(live)
            outcomes = self._motions([live[i][1] for i in order])
            for i, out in zip(order, outcomes, strict=True):
                gen = live[i][0]
                try:
                    live[i] = (gen, gen.send(out))
                except StopIteration as stop:
                    results[i] = stop.value
                    del live[i]
        # the record of how actions were simulated, in the order branch by branch would give
        for keys in touched:
            for key in keys:
                before[key] = self._simulated[key]
        self._simulated = before
        return [r for r in results if r is not None]

    # -- motions: integrated once ---------------------------------------------------------
    def _motion(self, request: MotionRequest) -> Any:
        """One controller action: the old path (``share=False``) or through the cache."""
        if not self.share:
            out = self.sim.simulate(
                request.arm, request.action, request.target, start=request.start,
                obstacles=request.obstacles, human_hand=request.human_hand, record=False,
            )  # fmt: skip
            self.motions_requested += 1
            self.motions_integrated += 1
            self.steps_integrated += out.steps
            return out
        return self._motions([request])[0]

    def _motions(self, requests: Sequence[MotionRequest]) -> list[Any]:
        """Outcomes of ``requests``: cached ones at once, each distinct rest integrated once
        (side by side, :func:`flexhrc.action.batch.simulate_many`), then cached.

        Two caches: by :func:`~flexhrc.action.batch.motion_key` (the moving arms' joints, the
        action, the target, the world), and — for a motion whose TCP path stayed beyond the
        reach of the human hand's objective all along — by the same key without the hand: the
        hand elsewhere, still beyond that reach of the whole path, gives the same motion (the
        objective never acts), with the least distance to the new hand reported."""
        from flexhrc.action.batch import motion_key, rebase, simulate_many

        keys = [motion_key(self.sim, r) for r in requests]
        outs: list[Any] = [None] * len(requests)
        todo: dict[Any, list[int]] = {}
        for i, (key, request) in enumerate(zip(keys, requests, strict=True)):
            if key is not None and key in self._motion_cache:
                self._motion_cache.move_to_end(key)
                outs[i] = rebase(self._motion_cache[key], request)
                continue
            if key is not None and key not in todo and self._far_cache:
                far = self._far_hit(key, request)
                if far is not None:
                    outs[i] = far
                    continue
            todo.setdefault(key if key is not None else ("unshared", i), []).append(i)
        self.motions_requested += len(requests)
        if todo:
            firsts = [requests[idx[0]] for idx in todo.values()]
            paths: list[Any] = []
            fresh = simulate_many(self.sim, firsts, paths)
            self.motions_integrated += len(fresh)
            self.steps_integrated += sum(o.steps for o in fresh)
            for (key, idx), request, out, path in zip(
                todo.items(), firsts, fresh, paths, strict=True
            ):
                if keys[idx[0]] is not None:
                    self._store(key, request, out, path)
                for i in idx:
                    outs[i] = rebase(out, requests[i])
        return outs

    def _store(self, key: Any, request: MotionRequest, out: Any, path: Any) -> None:
        from flexhrc.action.batch import far_key, hand_reach, least_distance

        self._motion_cache[key] = out
        if len(self._motion_cache) > self.cache_size:
            self._motion_cache.popitem(last=False)
        reach = hand_reach(self.sim, request)
        if reach is None or path is None:
            return
        hand = request.human_hand
        if hand is not None and least_distance(path, [(*hand, 0.0)]) < reach:
            return  # the hand's objective may have acted: only this hand gives this motion
        self._far_cache[far_key(key)] = (out, path, least_distance(path, request.obstacles))
        if len(self._far_cache) > self.cache_size // 8:  # these keep a path each
            self._far_cache.popitem(last=False)

    def _far_hit(self, key: Any, request: MotionRequest) -> Any:
        """The motion of ``request`` (of :func:`~flexhrc.action.batch.motion_key` ``key``)
        from the hand-free cache, or None."""
        from dataclasses import replace

        from flexhrc.action.batch import far_key, hand_reach, least_distance, rebase

        reach = hand_reach(self.sim, request)
        if reach is None:
            return None
        fkey = far_key(key)
        entry = self._far_cache.get(fkey)
        if entry is None:
            return None
        out, path, obstacles_min = entry
        hand = request.human_hand
        hand_min = float("inf") if hand is None else least_distance(path, [(*hand, 0.0)])
        if hand_min < reach:
            return None
        self._far_cache.move_to_end(fkey)
        self.motions_far += 1
        return replace(rebase(out, request), min_distance_m=min(obstacles_min, hand_min))

    def _branch(
        self,
        steps: Sequence[GroundAction],
        kb: KnowledgeBase,
        domain: Domain,
        touched: list[tuple[str, tuple[str, ...]]] | None = None,
    ) -> Generator[MotionRequest, Any, SimulationResult]:
        """One branch, simulated: yields each controller action it needs integrated (a
        :class:`~flexhrc.action.batch.MotionRequest`) and is sent its outcome back; the actions
        it simulates are added to ``touched``."""
        from flexhrc.action.batch import MotionRequest

        positions: dict[str, Vec3] = {}
        state = self.execution.state.copy()  # the robot as it is now
        durations: list[float] = []
        details: list[dict[str, object]] = []
        obstacles = self.obstacles(kb)
        hand = self.human_hand(kb)
        for action in steps:
            before = hands(action, positions, kb)
            _, motions = self.how(action, kb, positions, domain)
            if touched is not None:
                touched.append((action.name, action.args))
            if motions is None:
                ok, dt, why = self.human.step(action, positions, kb, domain)
                durations.append(dt)
                details.append(step_detail(action, dt, before, positions))
                if not ok:
                    return SimulationResult(False, durations, why, details)
                continue
            problem = self._check(action)
            if problem:
                return SimulationResult(False, [*durations, 0.0], problem, details)
            arm = self._arm(action)
            total, energy, min_d = 0.0, 0.0, float("inf")
            for kind, target in motions:
                out = yield MotionRequest(arm, kind, target, state, obstacles, hand)
                total += out.duration_s
                energy += out.energy
                min_d = min(min_d, out.min_distance_m)
                if not out.success:
                    durations.append(total)
                    return SimulationResult(False, durations, f"{action}: {out.reason}", details)
                state = out.final_state
            total += self.timing.robot_action_overhead
            durations.append(total)
            details.append(
                {
                    "action": str(action),
                    "agents": list(action.agents),
                    "t": round(total, 4),
                    "min_distance_m": min_d,
                    "energy": round(energy, 4),
                }
            )
            self._follow(action, motions, positions, kb)
            details[-1].update(hand_paths(before, positions))  # the planned path (the station)
        return SimulationResult(True, durations, None, details)

    def _follow(
        self, action: GroundAction, motions: Motion, positions: dict[str, Vec3], kb: KnowledgeBase
    ) -> None:
        """Where things are after the action, in knowledge-base terms (objects on places): the
        hands at the last target they aimed at, a carried object on its place."""
        target = next((goal for _, goal in reversed(motions) if goal is not None), None)
        if target is not None:
            for arm in action.agents:
                positions[arm] = target
        obj, place = action_targets(action, kb)
        if kind_of(action.schema).carries_object and obj and place and place in kb.objects:
            positions[obj] = self._pos(place, kb, positions)

    # -- ExecutionModel protocol ----------------------------------------------------------
    def execute(
        self, action: GroundAction, positions: dict[str, Vec3], kb: KnowledgeBase, domain: Domain
    ) -> StepReport:
        _, motions = self.how(action, kb, positions, domain)
        if motions is None:
            return self.human.execute(action, positions, kb, domain)
        from flexhrc.action.execution import HOLD_ACTIONS, Command, Disturbance

        problem = self._check(action)
        if problem:
            return StepReport("failed", 0.0, problem)
        em = self.execution
        em.obstacles = [*self.obstacles(kb)]
        em.human_hand = self.human_hand(kb)
        arm = self._arm(action)
        target = motions[-1][1] if motions else None
        for item in self._scheduled:
            if item[0] != action.schema.kind:
                continue
            item[3] += 1
            if item[3] == item[1]:
                params = dict(item[2])
                if params["kind"] == "blocked_path" and params.get("obstacle") is None:
                    # something appears right where the hand is going
                    params["obstacle"] = (
                        *(target or positions.get(action.agents[0], (0, 0, 0))),
                        0.03,
                    )
                em.inject(Disturbance(**params))
        total = 0.0
        held: str | None = None  # what a hold observed (a push undone): said in the report
        for kind, goal in motions:
            report = em.execute(Command(kind, arm, goal))
            total += report.duration_s
            if report.status != "done":
                return StepReport(report.status, total, report.reason)
            if kind in HOLD_ACTIONS and report.disturbances:
                held = report.reason
        self._follow(action, motions, positions, kb)
        return StepReport("done", total + self.timing.robot_action_overhead, held)

    def inject(self, disturbance: Any) -> Any:
        """Inject a disturbance into the simulated real robot's world (see ExecutionManager)."""
        return self.execution.inject(disturbance)

    def schedule(self, action: str, nth: int = 1, **disturbance: Any) -> None:
        """Inject a disturbance when the ``nth`` command of kind ``action`` starts, e.g.
        ``schedule("transport", kind="blocked_path", at_s=0.3, once=True)``: with ``at_s`` it
        happens during that command. A ``blocked_path`` without ``obstacle`` gets a 3 cm sphere
        right at that command's target."""
        from flexhrc.action.execution import Disturbance

        if "kind" not in disturbance:
            raise TypeError("schedule() needs kind=...")
        probe = dict(disturbance)
        if probe["kind"] == "blocked_path" and probe.get("obstacle") is None:
            probe["obstacle"] = (0.0, 0.0, 0.0, 0.03)
        Disturbance(**probe)  # validate now, not in the middle of a run
        self._scheduled.append([action, nth, disturbance, 0])
