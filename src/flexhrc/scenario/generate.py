"""Random cooperation tasks of any size: ``flexhrc scenario generate`` (issue 23, item 5).

:func:`generate` writes a valid scenario file (``flexhrc: 1``, docs/scenarios.md) for a task of
``actions`` steps, ``agents`` agents (robot arms and persons) and a width of ``width`` steps that
may run at once, fully determined by ``seed`` (the same arguments give the same bytes).

The task is an assembly tree, the shape of paper 000's AND/OR graphs (section IV): every step
``k`` puts part ``part_k`` into the product and has a node ``s<k>_done`` with the state formula
``done(part_k)``. A step needs the steps below it (its children: one AND hyper-arc with all of
them as children) or, at the bottom, its part on the bench (a leaf node ``s<k>_ready`` with
``loose(part_k)``). The root is the last step. The layers are grown from the root: each layer has
at most ``width`` steps and at most twice as many as the one above, so ``width`` is the most
steps that can be done at once.

Each step is done by one of its **alternatives** — hyper-arcs into the same node with the same
children (OR, paper eq. 7: once one is solved the others become infeasible), one action each, so
every cooperation path has exactly ``actions`` actions:

========== ===========================================================================
``any``    ``fit(?a, part_k)`` by an arm (weight 1) or ``fit_by_hand(?h, part_k)`` by a person (2)
``fasten`` ``fasten(?a, part_k)`` by an arm (1) or ``fasten_by_hand(?h, part_k)`` by a person (1)
``robot``  ``weld(?a, part_k)``: arms only
``human``  ``route_cable(?h, part_k)`` or ``inspect(?h, part_k)``: persons only
``joint``  ``lift_armI_armJ(part_k)``: two neighbouring arms at once (a joint action), and
           sometimes ``carry_by_hand(?h, part_k)`` by a person (weight 3)
========== ===========================================================================

**Reachability.** The arms stand side by side along the bench (``ARM_SPACING`` apart, reach
``REACH`` from the shoulder), the persons opposite; every part lists the arms that reach it
(``reachable_by``, the same as the reach spheres say), and some parts of steps a person may do lie
beyond every arm. A step's alternatives are only those someone can carry out, so every generated
task can be solved — by the arms alone where no person is needed, and by the persons where no arm
reaches. Durations are drawn per file (each operation's robot and person times), the rest is
travel: the analytic simulator (eq. 21) times an action as the hand's travel to the part plus its
duration.
"""

from __future__ import annotations

import itertools
import math
import random
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from flexhrc.errors import FlexhrcError

__all__ = [
    "MAX_ACTIONS",
    "MAX_AGENTS",
    "GenerateSpec",
    "generate",
    "generate_document",
    "write_generated",
]

MAX_ACTIONS = 1000
MAX_AGENTS = 64
MAX_SEED = 2**32 - 1
ARM_SPACING = 0.5  # metres between neighbouring shoulders, along y
REACH = 0.9  # metres from the shoulder
SHOULDER_Z = 0.433
PERSON_X = 1.1  # where the persons' hands wait
PERSON_SPEED = 0.8  # m/s
#: a step's kinds and their shares (``joint`` only with two arms or more)
KIND_WEIGHTS = {"any": 0.35, "fasten": 0.15, "robot": 0.15, "human": 0.15, "joint": 0.2}
#: the share of the parts of ``any``/``fasten``/``human`` steps that lie beyond every arm
UNREACHABLE = 0.2


@dataclass(frozen=True)
class GenerateSpec:
    """The arguments of a generated task, checked on creation (one :class:`FlexhrcError`
    naming the option): ``actions`` steps (1..:data:`MAX_ACTIONS`), ``agents`` agents
    (2..:data:`MAX_AGENTS`: at least one arm and one person), ``width`` (1..``actions``: the
    most steps that can run at once), ``seed`` (0..2**32-1) and ``persons`` (how many of the
    agents are persons, 1..``agents``-1; None: a quarter of them, at least one)."""

    actions: int
    agents: int
    width: int
    seed: int = 0
    persons: int | None = None

    def __post_init__(self) -> None:
        for option, value, lo, hi, what in (
            ("--actions", self.actions, 1, MAX_ACTIONS, "steps of the task"),
            ("--agents", self.agents, 2, MAX_AGENTS, "at least one arm and one person"),
            ("--seed", self.seed, 0, MAX_SEED, "a whole number"),
        ):
            if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
                raise FlexhrcError(
                    f"{option} must be a whole number in {lo}..{hi} ({what}), got {value!r}"
                )
        w = self.width
        if isinstance(w, bool) or not isinstance(w, int) or not 1 <= w <= self.actions:
            raise FlexhrcError(
                f"--width must be a whole number in 1..{self.actions} (--actions: at most every "
                f"step at once), got {w!r}"
            )
        p = self.persons
        if p is not None and (
            isinstance(p, bool) or not isinstance(p, int) or not 1 <= p <= self.agents - 1
        ):
            raise FlexhrcError(
                f"--persons must be a whole number in 1..{self.agents - 1} (--agents minus at "
                f"least one arm), got {p!r}"
            )

    @property
    def n_persons(self) -> int:
        return self.persons if self.persons is not None else max(1, self.agents // 4)

    @property
    def n_arms(self) -> int:
        return self.agents - self.n_persons

    @property
    def name(self) -> str:
        return f"gen_a{self.actions}_m{self.agents}_w{self.width}_s{self.seed}"

    def command(self) -> str:
        """The command line that writes this task."""
        extra = f" --persons {self.persons}" if self.persons is not None else ""
        return (
            f"flexhrc scenario generate --actions {self.actions} --agents {self.agents} "
            f"--width {self.width} --seed {self.seed}{extra}"
        )


def _layers(n: int, width: int) -> list[int]:
    """Layer sizes from the root down: 1, then at most twice the layer above and at most
    ``width``, until ``n`` steps are placed."""
    sizes = [1]
    left = n - 1
    while left > 0:
        size = min(width, 2 * sizes[-1], left)
        sizes.append(size)
        left -= size
    return sizes


def _n(count: int, word: str) -> str:
    return f"{count} {word}{'' if count == 1 else 's'}"


def _r(x: float) -> float:
    return round(x, 3)


class _Builder:
    """One generated task (see the module docstring)."""

    def __init__(self, spec: GenerateSpec):
        self.spec = spec
        self.rng = random.Random(f"flexhrc-generate-{spec.seed}")
        self.arms = [f"arm{i + 1}" for i in range(spec.n_arms)]
        self.persons = [f"op{j + 1}" for j in range(spec.n_persons)]
        self.arm_y = {
            a: _r((i - (len(self.arms) - 1) / 2) * ARM_SPACING) for i, a in enumerate(self.arms)
        }
        span = max(ARM_SPACING * (len(self.arms) - 1), 0.5)
        self.span = span
        rng = self.rng
        # each operation's seconds, drawn once per file: robot and person
        self.durations = {
            "fit": _r(rng.uniform(1.5, 3.0)),
            "fit_by_hand": _r(rng.uniform(2.0, 4.0)),
            "fasten": _r(rng.uniform(2.5, 4.0)),
            "fasten_by_hand": _r(rng.uniform(1.5, 3.0)),
            "weld": _r(rng.uniform(3.0, 5.0)),
            "route_cable": _r(rng.uniform(2.0, 4.0)),
            "inspect": _r(rng.uniform(1.0, 2.0)),
            "lift": _r(rng.uniform(2.0, 3.5)),
            "carry_by_hand": _r(rng.uniform(4.0, 6.0)),
        }
        self.joint_pairs: set[tuple[str, str]] = set()

    # -- the shape ------------------------------------------------------------------------
    def tree(self) -> tuple[list[list[int]], dict[int, list[int]]]:
        """Steps numbered 1..n bottom-up (the root is n), in layers from the root down, and
        each step's children."""
        n = self.spec.actions
        sizes = _layers(n, self.spec.width)
        layers: list[list[int]] = []
        k = n
        for size in sizes:
            layers.append(list(range(k, k - size, -1)))
            k -= size
        children: dict[int, list[int]] = {s: [] for layer in layers for s in layer}
        for upper, lower in itertools.pairwise(layers):
            # every step of the upper layer gets a child while there are enough, the rest at
            # random: the tree stays as wide as the layers
            order = list(upper)
            self.rng.shuffle(order)
            for i, step in enumerate(lower):
                parent = order[i] if i < len(order) else self.rng.choice(upper)
                children[parent].append(step)
        for c in children.values():
            c.sort()
        return layers, children

    def kinds(self) -> dict[int, str]:
        """Each step's kind: every kind at least once where there are steps enough, the rest
        drawn by :data:`KIND_WEIGHTS`."""
        n = self.spec.actions
        allowed = [k for k in KIND_WEIGHTS if k != "joint" or len(self.arms) >= 2]
        steps = list(range(1, n + 1))
        self.rng.shuffle(steps)
        out: dict[int, str] = {}
        for kind, step in zip(allowed, steps, strict=False):
            out[step] = kind
        weights = [KIND_WEIGHTS[k] for k in allowed]
        for step in steps[len(allowed) :]:
            out[step] = self.rng.choices(allowed, weights)[0]
        return out

    # -- the places ----------------------------------------------------------------------
    def reach(self, pos: tuple[float, float, float]) -> list[str]:
        return [
            a for a in self.arms if math.dist((0.0, self.arm_y[a], SHOULDER_Z), pos) <= REACH - 1e-6
        ]

    def part_position(self, kind: str) -> tuple[tuple[float, float, float], tuple[str, str] | None]:
        """Where a step's part lies (and the pair of arms of a joint step)."""
        rng = self.rng
        if kind == "joint":
            i = rng.randrange(len(self.arms) - 1)
            pair = (self.arms[i], self.arms[i + 1])
            y = (self.arm_y[pair[0]] + self.arm_y[pair[1]]) / 2 + rng.uniform(-0.05, 0.05)
            return (_r(rng.uniform(0.35, 0.5)), _r(y), 0.0), pair
        if kind != "robot" and rng.random() < UNREACHABLE:  # beyond every arm: persons only
            y = rng.uniform(-self.span / 2, self.span / 2)
            return (_r(rng.uniform(0.98, 1.05)), _r(y), 0.0), None
        arm = rng.choice(self.arms)
        y = self.arm_y[arm] + rng.uniform(-0.2, 0.2)
        return (_r(rng.uniform(0.35, 0.6)), _r(y), 0.0), None

    # -- the document ----------------------------------------------------------------------
    def document(self) -> dict[str, Any]:
        spec = self.spec
        layers, children = self.tree()
        kinds = self.kinds()
        nodes: list[dict[str, Any]] = []
        hyperarcs: list[dict[str, Any]] = []
        objects: dict[str, Any] = {}
        facts: list[str] = []
        counts = {"alternatives": 0, "joint": 0, "robot_only": 0, "human_only": 0, "unreachable": 0}
        for k in range(1, spec.actions + 1):
            kind = kinds[k]
            part = f"part_{k}"
            pos, pair = self.part_position(kind)
            reach = self.reach(pos)
            objects[part] = {
                "type": "part",
                "position": list(pos),
                "size": [0.05, 0.05, 0.05],
                "reachable_by": reach,
            }
            facts.append(f"loose({part})")
            kids = [f"s{c}_done" for c in children[k]]
            if not kids:
                nodes.append({"name": f"s{k}_ready", "state": f"loose({part})"})
                kids = [f"s{k}_ready"]
            nodes.append({"name": f"s{k}_done", "state": f"done({part})"})
            alts = self.alternatives(k, kind, part, reach, pair)
            if len(alts) > 1:
                counts["alternatives"] += 1
            if not reach:
                counts["unreachable"] += 1
            counts["joint"] += kind == "joint"
            counts["robot_only"] += all(a[0] in ("arm", "joint") for a in alts)
            counts["human_only"] += all(a[0] == "person" for a in alts)
            for who, action, weight in alts:
                hyperarcs.append(
                    {
                        "name": f"s{k}_{who}",
                        "children": kids,
                        "parent": f"s{k}_done",
                        "weight": weight,
                        "actions": [action],
                    }
                )
        root = f"s{spec.actions}_done"
        agents: dict[str, Any] = {}
        for a in self.arms:
            y = self.arm_y[a]
            agents[a] = {
                "kind": "robot",
                "types": ["arm"],
                "base": [0.0, y, SHOULDER_Z],
                "rest": [0.307, y, 0.587],
                "reach": REACH,
            }
        person_y = {
            p: _r((j - (len(self.persons) - 1) / 2) * self.span / max(len(self.persons), 1))
            for j, p in enumerate(self.persons)
        }
        for p in self.persons:
            agents[p] = {"kind": "human", "types": ["person"], "hand": [PERSON_X, person_y[p], 0.1]}
        width = max(len(layer) for layer in layers)
        description = (
            f"A generated assembly of {spec.actions} steps ({len(layers)} layers, up to {width} "
            f"at once) for {_n(len(self.arms), 'arm')} and {_n(len(self.persons), 'person')}: "
            f"{counts['alternatives']} steps with alternatives, {counts['joint']} joint, "
            f"{counts['robot_only']} robot-only, {counts['human_only']} person-only, "
            f"{counts['unreachable']} parts no arm reaches."
        )
        return {
            "flexhrc": 1,
            "name": spec.name,
            "description": description,
            "graphs": {spec.name: {"root": root, "nodes": nodes, "hyperarcs": hyperarcs}},
            "domain": {"agents": agents, "actions": self.actions()},
            "world": {"objects": objects, "facts": facts},
            "humans": [
                {"name": p, "profile": "passive", "speed": PERSON_SPEED} for p in self.persons
            ],
            "simulator": "analytic",
        }

    def alternatives(
        self,
        k: int,
        kind: str,
        part: str,
        reach: list[str],
        pair: tuple[str, str] | None,
    ) -> list[tuple[str, str, int]]:
        """``(who, action, weight)`` of each hyper-arc into step ``k``: only those someone can
        carry out (an arm's needs an arm that reaches the part)."""
        arm = f"(?a, {part})"
        hand = f"(?h, {part})"
        if kind == "robot":
            return [("arm", f"weld{arm}", 1)]
        if kind == "human":
            op = "route_cable" if self.rng.random() < 0.5 else "inspect"
            return [("person", f"{op}{hand}", 1)]
        if kind == "joint":
            assert pair is not None
            self.joint_pairs.add(pair)
            alts = [("joint", f"lift_{pair[0]}_{pair[1]}({part})", 1)]
            if self.rng.random() < 0.5:
                alts.append(("person", f"carry_by_hand{hand}", 3))
            return alts
        robot, person, weight = (
            ("fit", "fit_by_hand", 2) if kind == "any" else ("fasten", "fasten_by_hand", 1)
        )
        alts = [("arm", f"{robot}{arm}", 1)] if reach else []
        return [*alts, ("person", f"{person}{hand}", weight)]

    def actions(self) -> dict[str, Any]:
        d = self.durations

        def schema(who: str, duration: float) -> dict[str, Any]:
            var, typ = ("?a", "arm") if who == "arm" else ("?h", "person")
            return {
                "parameters": {var: typ, "?p": "part"},
                "agents": {"choice": var},
                "pre": ["loose(?p)"],
                "add": ["done(?p)"],
                "delete": ["loose(?p)"],
                "moves_to": "?p",
                "duration": duration,
            }

        out: dict[str, Any] = {}
        for name in ("fit", "fasten", "weld"):
            out[name] = schema("arm", d[name])
        for name in ("fit_by_hand", "fasten_by_hand", "route_cable", "inspect", "carry_by_hand"):
            out[name] = schema("person", d[name])
        for a, b in sorted(self.joint_pairs, key=lambda p: self.arms.index(p[0])):
            out[f"lift_{a}_{b}"] = {
                "parameters": {"?p": "part"},
                "agents": {"joint": [a, b]},
                "pre": ["loose(?p)"],
                "add": ["done(?p)"],
                "delete": ["loose(?p)"],
                "moves_to": "?p",
                "duration": d["lift"],
            }
        out["rest"] = {"parameters": {"?a": "arm"}, "agents": {"choice": "?a"}, "kind": "rest"}
        return out


def generate_document(
    *, actions: int, agents: int, width: int, seed: int = 0, persons: int | None = None
) -> dict[str, Any]:
    """The generated scenario as a document (what :func:`generate` writes as YAML)."""
    spec = GenerateSpec(actions, agents, width, seed, persons)
    return _Builder(spec).document()


def generate(
    *, actions: int, agents: int, width: int, seed: int = 0, persons: int | None = None
) -> str:
    """The YAML text of a generated scenario (see the module docstring): a comment saying how
    it was made, then the document. The same arguments give the same text."""
    import yaml

    spec = GenerateSpec(actions, agents, width, seed, persons)
    doc = _Builder(spec).document()

    class _Dumper(yaml.SafeDumper):  # shared lists written out, never as &id001 / *id001
        def ignore_aliases(self, data: Any) -> bool:
            return True

    body = yaml.dump(doc, Dumper=_Dumper, sort_keys=False, default_flow_style=None, width=100)
    head = (
        f"# Generated by: {spec.command()}\n"
        "# (flexhrc.scenario.generate; docs/scenarios.md#generated-tasks). Validate it with\n"
        "# flexhrc scenario validate FILE, run it with flexhrc run FILE.\n"
    )
    return head + body


def write_generated(
    path: str | Path,
    *,
    actions: int,
    agents: int,
    width: int,
    seed: int = 0,
    persons: int | None = None,
    force: bool = False,
    option: str = "-o",
) -> Path:
    """Write a generated scenario to ``path`` (``.yaml``/``.yml``), atomically. The arguments
    and the path are checked before anything is built; an existing file is kept unless
    ``force``."""
    from flexhrc.files import OutputPathError, atomic_write_text, check_output

    GenerateSpec(actions, agents, width, seed, persons)
    target = check_output(path, option=option, suffixes={".yaml", ".yml"})
    if target.exists() and not force:
        raise OutputPathError(f"{option} {target}: already exists (use --force to overwrite it)")
    text = generate(actions=actions, agents=agents, width=width, seed=seed, persons=persons)
    atomic_write_text(target, text)
    return target
