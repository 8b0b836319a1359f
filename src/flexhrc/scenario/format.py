"""Reading and checking scenario files (``flexhrc: 1``).

:func:`check` reads a scenario file and returns the :class:`Scenario` it describes (None when it
has errors) and every :class:`Fault` found, each with the file and line it is about — the
scenario file, the domain file or the graph file. :func:`parse` raises the first error instead.

Faults that stop a scenario from running (errors): a malformed document, an unknown key, a
graph file that is missing or invalid, an unknown action in a hyper-arc, an action parameter of
an undeclared type, an undeclared agent, an object of an unknown type, a malformed pose, a
hyper-arc whose actions no declared agent can do. A predicate that no fact or effect can ever
make true is a warning: the scenario runs, but the element using it will never be reached.
"""

from __future__ import annotations

import fnmatch
import math
import os
import re
import reprlib
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from flexhrc.errors import FlexhrcError, FormatError
from flexhrc.events import DECISION_POLICIES, FAILURE_POLICIES, WORKSPACE_M
from flexhrc.logic import Literal, parse_conjunction, parse_literal
from flexhrc.representation import HierarchicalGraph
from flexhrc.representation.graph import AndOrGraph
from flexhrc.scenario.model import (
    PROFILES,
    SIMULATORS,
    HumanSpec,
    ObjectSpec,
    Scenario,
    WorldSpec,
)
from flexhrc.taskmanager.domain import ActionSchema, Domain, _line
from flexhrc.taskmanager.kinds import TIMINGS, find_action_kind, unknown_kind
from flexhrc.taskmanager.utility import parse_utility

FORMAT_VERSION = 1

# --------------------------------------------------------------------------- declarations --
# Every key a scenario gives an object, an agent or an operator is declared once, here: what it
# holds (said in the message when it holds something else) and the check that turns the file's
# value into the scenario's. A value of another kind is refused, never coerced: a string is no
# list of names (``reachable_by: arm`` is not ``[a, r, m]``), ``'no'`` is no boolean.


class _Bad(ValueError):
    """A declared value check failed; the message says what the key holds."""


def show(value: Any, limit: int = 60) -> str:
    """``repr(value)``, cut to ``limit`` characters: a message quotes a value, never a file."""
    text = _short_repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _short_repr(value: Any) -> str:
    r = reprlib.Repr()
    r.maxstring = r.maxother = 60
    r.maxlist = r.maxtuple = r.maxdict = r.maxset = 6
    r.maxlevel = 3
    return r.repr(value)


@dataclass(frozen=True)
class Key:
    """One declared key: ``what`` it holds (for messages) and ``check``, which returns the
    value as the scenario keeps it or raises :class:`_Bad`."""

    what: str
    check: Callable[[Any], Any]
    #: the fault's words: ``{key}``, ``{what}``, ``{value}`` (the value, cut short)
    template: str = "{key} must be {what}, got {value}"

    def fault(self, key: str, value: Any, exc: _Bad) -> str:
        if exc.args:  # the check knows better what is wrong (a position out of bounds)
            return f"{key} {show(value)} {exc.args[0]}"
        return self.template.format(key=key, what=self.what, value=show(value))


def _number(lo: float, hi: float, *, hi_open: bool = False) -> Callable[[Any], float]:
    """A finite number in (lo, hi] (or (lo, hi) with ``hi_open``)."""

    def check(v: Any) -> float:
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise _Bad
        if v <= lo or v > hi or (hi_open and v == hi):
            raise _Bad
        return float(v)

    return check


def _boolean(v: Any) -> bool:
    if not isinstance(v, bool):
        raise _Bad
    return v


def _name(v: Any) -> str:
    if not isinstance(v, str) or not v.strip():
        raise _Bad
    return v


def _names(v: Any) -> tuple[str, ...]:
    if not isinstance(v, list) or not all(isinstance(x, str) and x.strip() for x in v):
        raise _Bad
    return tuple(v)


def _position(v: Any) -> tuple[float, float, float]:
    if not _is_pose(v):
        raise _Bad
    if any(abs(x) > WORKSPACE_M for x in v):
        raise _Bad(
            f"is outside the workspace (within {WORKSPACE_M:g} m of the origin on every axis)"
        )
    return (float(v[0]), float(v[1]), float(v[2]))


def _attrs(v: Any) -> dict[str, Any]:
    if not isinstance(v, Mapping) or not all(isinstance(k, str) for k in v):
        raise _Bad
    return dict(v)


def _choice(*names: str) -> Callable[[Any], str]:
    def check(v: Any) -> str:
        if not isinstance(v, str) or v not in names:
            raise _Bad
        return v

    return check


def _size_key(v: Any) -> dict[str, float]:
    size = _size(v)
    if size is None:
        raise _Bad
    return size


_POSITION = Key(
    "three finite numbers [x, y, z] in metres", _position, "malformed pose {key}: {value} ({what})"
)
_NAMES = Key("a list of names, such as [arm]", _names)

#: ``world.objects.NAME``
OBJECT_DECL: dict[str, Key] = {
    "type": Key("a type name", _name),
    "position": _POSITION,
    "size": Key("a list of up to three positive numbers, or {name: number}", _size_key),
    "fixed": Key("true or false", _boolean),
    "reachable_by": Key("a list of agent names, such as [arm]", _names),
    "attrs": Key("a mapping {name: value}", _attrs),
}
#: ``domain.agents.NAME``
AGENT_DECL: dict[str, Key] = {
    "kind": Key("human or robot", _choice("human", "robot")),
    "types": Key("a list of type names, such as [robot]", _names),
    "base": _POSITION,
    "rest": _POSITION,
    "hand": _POSITION,
    "reach": Key("a number of metres in (0, 10]", _number(0.0, 10.0)),
    "speed": Key("a number of m/s in (0, 100)", _number(0.0, 100.0, hi_open=True)),
}
#: ``humans[i]``
HUMAN_DECL: dict[str, Key] = {
    "name": Key("a human agent of the domain", _name),
    "profile": Key(f"one of {', '.join(PROFILES)}", _choice(*PROFILES)),
    "speed": Key("a number of m/s in (0, 100)", _number(0.0, 100.0, hi_open=True)),
}

TOP_KEYS = {
    "flexhrc",
    "name",
    "description",
    "graph",
    "graphs",
    "top",
    "hyperarc_actions",
    "node_states",
    "domain",
    "world",
    "humans",
    "robot",
    "simulator",
    "on_failure",
    "policy",
    "answer_timeout",
    "timing",
    "utility",
}
WORLD_KEYS = {"objects", "places", "facts", "supertypes"}


@dataclass(frozen=True)
class Fault:
    """One problem of a scenario: ``FILE:LINE: message`` (``warning: `` for warnings)."""

    source: str
    line: int | None
    message: str
    severity: str = "error"  # error | warning

    def __str__(self) -> str:
        where = f"{self.source}:{self.line}" if self.line else self.source
        tag = "warning: " if self.severity == "warning" else ""
        return f"{where}: {tag}{self.message}"


class ScenarioError(FormatError):
    """A scenario with errors; :attr:`faults` has them all, the message shows the first."""

    def __init__(self, faults: list[Fault]):
        self.faults = faults
        first = faults[0]
        more = (
            f" (and {len(faults) - 1} more: flexhrc scenario validate)" if len(faults) > 1 else ""
        )
        super().__init__(first.message + more, first.source, first.line)


class _Checker:
    def __init__(self, path: Path):
        self.path = path
        self.faults: list[Fault] = []
        self.names: set[str] = set()  # every object and place named, even a malformed one
        self.types: set[str] = set()  # every object type named, even of a malformed object

    def error(self, message: str, line: int | None, source: str | Path | None = None) -> None:
        if len(message) > 1000:  # a message quotes the file, it never repeats it
            message = message[:1000] + "..."
        self.faults.append(Fault(str(source or self.path), line, message))

    def warn(self, message: str, line: int | None, source: str | Path | None = None) -> None:
        self.faults.append(Fault(str(source or self.path), line, message, "warning"))

    def fields(
        self, d: Mapping[Any, Any], decl: Mapping[str, Key], what: str, src: Any = None
    ) -> dict[str, Any]:
        """``d``'s keys checked against their declaration ``decl``: a fault for each unknown
        key and each bad value (at its line), the values of the good ones."""
        out: dict[str, Any] = {}
        for key, value in d.items():
            k = decl.get(key) if isinstance(key, str) else None
            if k is None:
                self.error(
                    f"{what}: unknown key {show(key)} (allowed: {', '.join(decl)})",
                    _line(d, key),
                    src,
                )
                continue
            try:
                out[key] = k.check(value)
            except _Bad as exc:
                self.error(f"{what}: {k.fault(key, value, exc)}", _line(d, key) or _line(d), src)
        return out

    def from_format_error(self, exc: FormatError) -> None:
        self.faults.append(Fault(exc.source or str(self.path), exc.line, exc.message))

    @property
    def failed(self) -> bool:
        return any(f.severity == "error" for f in self.faults)


# ------------------------------------------------------------------------------ entry points --
def check(path: str | Path) -> tuple[Scenario | None, list[Fault]]:
    """Read and check a scenario file: (the scenario or None, every fault)."""
    from flexhrc.files import read_text
    from flexhrc.representation.formats.yaml_format import read_yaml

    path = Path(path)
    c = _Checker(path)
    try:
        read_text(path)  # missing, folder, unreadable, binary: one clear error
        doc = read_yaml(path)
    except FormatError as exc:
        c.from_format_error(exc)
        return None, c.faults
    except FlexhrcError as exc:
        c.error(str(exc), None)
        return None, c.faults
    if not isinstance(doc, dict):
        c.error("a scenario file must be a mapping (flexhrc: 1, name, graph, domain, ...)", 1)
        return None, c.faults
    if "flexhrc" not in doc:
        c.error("not a scenario file: 'flexhrc: 1' is missing", 1)
        return None, c.faults
    version = doc.get("flexhrc")
    if isinstance(version, bool) or version != FORMAT_VERSION:  # true == 1 in Python
        c.error(
            f"unsupported scenario format {doc.get('flexhrc')!r} (this flexhrc reads "
            f"{FORMAT_VERSION})",
            _line(doc, "flexhrc"),
        )
        return None, c.faults
    for key in doc:
        if key not in TOP_KEYS:
            c.error(
                f"unknown key {key!r} (allowed: {', '.join(sorted(TOP_KEYS))})", _line(doc, key)
            )
    scenario = _build(doc, c)
    return (None if c.failed else scenario), c.faults


def parse(path: str | Path) -> Scenario:
    """Read a scenario file; raise :class:`ScenarioError` with every error if it has any."""
    scenario, faults = check(path)
    errors = [f for f in faults if f.severity == "error"]
    if errors or scenario is None:
        raise ScenarioError(errors or [Fault(str(path), None, "invalid scenario")])
    return scenario


#: keys of a YAML graph file; a ``flexhrc: 1`` file with any other top-level key of a scenario
#: (``domain``, ``graph``, ``world``, ...) is a scenario file
GRAPH_FILE_KEYS = {"flexhrc", "top", "graphs", "description"}
_SCENARIO_KEY = re.compile(
    r"^(?:" + "|".join(sorted(TOP_KEYS - GRAPH_FILE_KEYS)) + r")\s*:", re.MULTILINE
)


def is_scenario_file(path: str | Path) -> bool:
    """Whether ``path`` is a scenario file rather than a graph file: a YAML file with a
    top-level key only scenarios have (``name``, ``graph``, ``domain``, ``world``, ...). A
    look at the text, not a parse: a large graph file is read once, by its reader."""
    if not str(path).lower().endswith((".yaml", ".yml")):
        return False
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            text = f.read()
    except OSError:
        return False  # the graph reader says what is wrong with it
    return _SCENARIO_KEY.search(text) is not None


def graph_of(path: str | Path) -> HierarchicalGraph:
    """The task graph of a file, whether a graph file or a scenario file.

    A graph file (ANDOR text or YAML) is loaded by :func:`flexhrc.representation.load`; of a
    scenario file only the graph is read — its inline ``graphs:`` block or the file its
    ``graph:`` names, with ``hyperarc_actions`` applied — and checked as the graph commands
    check a graph file (the rest of the scenario is ``validate``'s business). Every fault is a
    :class:`~flexhrc.errors.FormatError` naming the file and line (a :class:`ScenarioError`
    for a scenario file).
    """
    from flexhrc.representation.formats import load
    from flexhrc.representation.formats.yaml_format import read_yaml

    if not is_scenario_file(path):
        return load(path)
    p = Path(path)
    c = _Checker(p)
    doc = read_yaml(p)
    if not isinstance(doc, Mapping):
        c.error("a scenario file must be a mapping (flexhrc: 1, name, graph, domain, ...)", 1)
        raise ScenarioError(c.faults)
    graph = _graph(doc, c)
    if graph is not None and "hyperarc_actions" in doc:
        _attach_actions(graph, doc["hyperarc_actions"], c, _line(doc, "hyperarc_actions"))
    if graph is not None and "node_states" in doc:
        _attach_states(graph, doc["node_states"], c, _line(doc, "node_states"))
    errors = [f for f in c.faults if f.severity == "error"]
    if errors or graph is None:
        raise ScenarioError(errors or [Fault(str(p), None, "no task graph")])
    return graph


# ------------------------------------------------------------------------------- building --
def _build(doc: Any, c: _Checker) -> Scenario | None:
    path = c.path
    for key, what in (("name", "a name"), ("description", "a text")):
        if key in doc and not isinstance(doc[key], str):
            c.error(f"{key} must be {what} (a string), got {show(doc[key])}", _line(doc, key))
    name = str(doc.get("name") or path.stem.removesuffix(".scenario"))
    description = str(doc.get("description") or "")
    graph = _graph(doc, c)
    domain, domain_doc, domain_src = _domain(doc, c)
    world = _world(doc.get("world"), c, _line(doc, "world"))
    humans = _humans(doc.get("humans"), c, _line(doc, "humans"), domain)
    simulator = _one_of(doc, "simulator", SIMULATORS, "analytic", c)
    on_failure = _one_of(doc, "on_failure", FAILURE_POLICIES, None, c)
    policy = _one_of(doc, "policy", DECISION_POLICIES, None, c)
    answer_timeout = doc.get("answer_timeout")
    if answer_timeout is not None and (
        isinstance(answer_timeout, bool)
        or not isinstance(answer_timeout, int | float)
        or not 0 < answer_timeout < 1e6
    ):
        c.error(
            f"answer_timeout {show(answer_timeout)}: a number of seconds > 0",
            _line(doc, "answer_timeout"),
        )
        answer_timeout = None
    timing = _one_of(doc, "timing", TIMINGS, "default", c)
    utility, problems = parse_utility(doc.get("utility"), domain)
    block = doc.get("utility")
    for message, spot in problems:
        where = _line(block, spot) if spot is not None and isinstance(block, Mapping) else None
        c.error(message, where or _line(doc, "utility"))
    robot = doc.get("robot") or {}
    if not isinstance(robot, Mapping):
        c.error("robot must be a mapping", _line(doc, "robot"))
        robot = {}
    if graph is None or domain is None or world is None:
        return None
    if "hyperarc_actions" in doc:
        _attach_actions(graph, doc["hyperarc_actions"], c, _line(doc, "hyperarc_actions"))
    if "node_states" in doc:
        _attach_states(graph, doc["node_states"], c, _line(doc, "node_states"))
    _check_semantics(graph, domain, domain_doc, domain_src, world, humans, c)
    _check_kind_targets(domain, domain_doc, domain_src, c)
    for h in humans:  # an operator's speed is the analytic simulator's human speed
        agent = domain.agents.get(h.name)
        if agent is not None:
            domain.agents[h.name] = replace(agent, params={**agent.params, "speed": h.speed})
    return Scenario(
        name,
        description,
        graph,
        domain,
        world,
        tuple(humans),
        simulator,
        dict(robot),
        path,
        tuple(str(f) for f in c.faults if f.severity == "warning"),
        on_failure=on_failure,
        policy=policy,
        answer_timeout=None if answer_timeout is None else float(answer_timeout),
        timing=timing,
        utility=utility,
    )


def _one_of(doc: Any, key: str, choices: Iterable[str], default: Any, c: _Checker) -> Any:
    """The value of an optional key that names one of ``choices``; ``default`` (after an error
    at the key's line) when it names none of them."""
    value = doc.get(key, default)
    if (value is None and default is None) or (isinstance(value, str) and value in choices):
        return value
    c.error(f"{key} {show(value)}: choose one of {', '.join(choices)}", _line(doc, key))
    return default


def _graph(doc: Any, c: _Checker) -> HierarchicalGraph | None:
    from flexhrc.representation.formats import load

    if ("graph" in doc) == ("graphs" in doc):
        c.error("give the task graph as 'graph: FILE' or as an inline 'graphs:' document", 1)
        return None
    try:
        if "graphs" in doc:
            return _inline_graph(doc, c.path)
        g = doc["graph"]
        if isinstance(g, Mapping):
            return _inline_graph(g, c.path)
        if not isinstance(g, str) or not g.strip():
            c.error("graph must be a file name or an inline graphs document", _line(doc, "graph"))
            return None
        target = c.path.parent / g
        if not target.is_file():
            c.error(f"graph file {g!r} not found (looked for {target})", _line(doc, "graph"))
            return None
        hierarchy = load(target)
        return hierarchy
    except FormatError as exc:
        c.from_format_error(exc)
        return None


def _inline_graph(doc: Any, path: Path) -> HierarchicalGraph:
    """An inline ``graphs:`` document, in the YAML graph format (files relative to ``path``)."""
    from flexhrc.representation.formats import yaml_format as yf

    graphs_d = doc.get("graphs")
    if not isinstance(graphs_d, dict) or not graphs_d:
        raise FormatError("'graphs' must be a non-empty mapping", path, _line(doc, "graphs"))
    top = str(doc.get("top", next(iter(graphs_d))))
    graphs: dict[str, AndOrGraph] = {}
    for key, gd in graphs_d.items():
        key = str(key)
        if not isinstance(gd, dict):
            raise FormatError(f"graph {key!r} must be a mapping", path, _line(graphs_d, key))
        # the YAML graph reader's own helpers: an inline document reads like a graph file
        if "file" in gd:
            including = (os.path.realpath(path),)  # file: references stay in its folder
            graphs.update(yf._load_external(key, path, gd, including))  # type: ignore[arg-type]
        else:
            graphs[key] = yf._graph_from_dict(key, gd, path, _line(graphs_d, key))  # type: ignore[arg-type]
    if top not in graphs:
        raise FormatError(f"top graph {top!r} is not defined under 'graphs'", path, _line(doc))
    hierarchy = HierarchicalGraph(graphs, top)
    hierarchy.validate()
    return hierarchy


def _domain(doc: Any, c: _Checker) -> tuple[Domain | None, Any, Path]:
    from flexhrc.representation.formats.yaml_format import read_yaml

    if "domain" not in doc:
        c.error("'domain' is missing (agents and actions: a file name or inline)", 1)
        return None, None, c.path
    d = doc["domain"]
    src = c.path
    if isinstance(d, str):
        src = c.path.parent / d
        if not src.is_file():
            c.error(f"domain file {d!r} not found (looked for {src})", _line(doc, "domain"))
            return None, None, c.path
        try:
            d = read_yaml(src)
        except FormatError as exc:
            c.from_format_error(exc)
            return None, None, src
    if not isinstance(d, Mapping):
        c.error("domain must be a mapping with 'agents' and 'actions'", _line(doc, "domain"), src)
        return None, None, src
    n0 = len(c.faults)
    _precheck_domain(d, c, src)
    if len(c.faults) > n0:
        return None, d, src
    try:
        return Domain.from_dict(d, src), d, src
    except FormatError as exc:
        c.from_format_error(exc)
    except FlexhrcError as exc:
        c.error(str(exc), _line(d), src)
    return None, d, src


def _precheck_domain(d: Mapping[str, Any], c: _Checker, src: Path) -> None:
    """Faults Domain.from_dict would raise one at a time: collect them all, with lines."""
    agents = d.get("agents") or {}
    if not isinstance(agents, Mapping):
        c.error("agents must be a mapping {name: {kind: human|robot, types: [...]}}", _line(d), src)
        return
    for name, ad in agents.items():
        if not isinstance(ad, Mapping) or ad.get("kind") not in ("human", "robot"):
            c.error(f"agent {show(name)}: needs kind: human or robot", _line(agents, name), src)
            continue
        c.fields(ad, AGENT_DECL, f"agent {show(name)}", src)
    for section in ("actions", "processes"):
        block = d.get(section) or {}
        if not isinstance(block, Mapping):
            c.error(f"{section} must be a mapping", _line(d, section), src)
            continue
        for aname, sd in block.items():
            if not isinstance(sd, Mapping):
                continue
            if "kind" in sd:
                why = unknown_kind(str(sd["kind"]))
                if why:
                    c.error(f"{section[:-1]} {aname!r}: {why}", _line(sd, "kind"), src)
            spec = sd.get("agents")
            names: list[str] = []
            if isinstance(spec, str) and not spec.startswith("?"):
                names = [spec]
            elif isinstance(spec, Mapping) and "single" in spec:
                names = [str(spec["single"])]
            elif isinstance(spec, Mapping) and "joint" in spec and isinstance(spec["joint"], list):
                names = [str(x) for x in spec["joint"]]
                _check_joint(section[:-1], aname, names, agents, c, _line(sd, "agents"), src)
            _check_free_variables(section[:-1], aname, sd, c, src)
            for n in names:
                if n not in agents:
                    c.error(
                        f"{section[:-1]} {aname!r}: undeclared agent {n!r} (agents: "
                        f"{', '.join(map(str, agents)) or 'none'})",
                        _line(sd, "agents"),
                        src,
                    )


_VARIABLE = re.compile(r"\?[A-Za-z_][\w-]*")


def _check_free_variables(
    what: str, name: Any, sd: Mapping[str, Any], c: _Checker, src: Path
) -> None:
    """A variable of ``add`` or ``delete`` that is no parameter: nothing binds it, so the
    effect is never ground. (In ``pre`` and ``until`` such a variable means *some* object:
    ``pre: ["in(?b, ?box)"]`` holds when any ball is in the box.)"""
    params = sd.get("parameters")
    if not isinstance(params, Mapping):
        return
    known = {str(v) for v in params}
    for key in ("add", "delete"):
        value = sd.get(key)
        texts = [value] if isinstance(value, str) else value if isinstance(value, list) else []
        free = sorted({v for t in texts for v in _VARIABLE.findall(str(t))} - known)
        if free:
            c.error(
                f"{what} {show(name)}: {key} uses {', '.join(free)}, which is no parameter "
                f"(parameters: {', '.join(sorted(known)) or 'none'})",
                _line(sd, key) or _line(sd),
                src,
            )


def _check_joint(
    what: str,
    name: Any,
    names: list[str],
    agents: Mapping[Any, Any],
    c: _Checker,
    line: int | None,
    src: Path,
) -> None:
    """A joint action is one command for several robot arms at once (a bimanual action)."""
    humans = [
        n for n in names if isinstance(agents.get(n), Mapping) and agents[n].get("kind") == "human"
    ]
    if humans:
        c.error(
            f"{what} {show(name)}: joint agents must be robot arms; {', '.join(humans)} is a "
            "human (give the operator and the arm each an action of their own)",
            line,
            src,
        )
    if len(names) < 2 or len(set(names)) != len(names):
        c.error(
            f"{what} {show(name)}: joint needs two or more different agents, got {show(names)}",
            line,
            src,
        )


def _is_pose(p: Any) -> bool:
    if not isinstance(p, list | tuple) or len(p) != 3:
        return False
    return all(
        isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in p
    )


def _world(w: Any, c: _Checker, line: int | None) -> WorldSpec | None:
    if w is None:
        return WorldSpec()
    if not isinstance(w, Mapping):
        c.error("world must be a mapping (objects, places, facts, supertypes)", line)
        return None
    for key in w:
        if key not in WORLD_KEYS:
            c.error(
                f"unknown key {key!r} in world (allowed: {', '.join(sorted(WORLD_KEYS))})",
                _line(w, key),
            )
    objects: list[ObjectSpec] = []
    od = w.get("objects") or {}
    if not isinstance(od, Mapping):
        c.error(
            "world.objects must be a mapping {NAME: {type, position, ...}}", _line(w, "objects")
        )
        od = {}
    c.names.update(str(n) for n in od)
    for name, spec in od.items():
        ln = _line(od, name)
        if not isinstance(spec, Mapping):
            c.error(f"object {show(name)}: must be a mapping {{type, position, size, fixed}}", ln)
            continue
        n0 = len(c.faults)
        got = c.fields(spec, OBJECT_DECL, f"object {show(name)}")
        if isinstance(got.get("type"), str):
            c.types.add(got["type"])
        for key in ("type", "position"):
            if key not in spec:
                c.error(f"object {show(name)}: needs a {key} ({OBJECT_DECL[key].what})", ln)
        if len(c.faults) > n0:
            continue
        attrs = dict(got.get("attrs", {}))
        if "reachable_by" in got:
            attrs["reachable_by"] = list(got["reachable_by"])
        objects.append(
            ObjectSpec(
                str(name),
                got["type"],
                got["position"],
                got.get("size", {}),
                got.get("fixed", False),
                attrs,
            )
        )
    places: dict[str, tuple[float, float, float]] = {}
    pd = w.get("places") or {}
    if not isinstance(pd, Mapping):
        c.error("world.places must be a mapping {NAME: [x, y, z]}", _line(w, "places"))
        pd = {}
    c.names.update(str(n) for n in pd)
    for name, pos in pd.items():
        try:
            places[str(name)] = _POSITION.check(pos)
        except _Bad as exc:
            why = exc.args[0] if exc.args else "(three finite numbers [x, y, z])"
            c.error(f"place {show(name)}: malformed pose {show(pos)} {why}", _line(pd, name))
    facts: list[Literal] = []
    fl = w.get("facts") or []
    if not isinstance(fl, list):
        c.error("world.facts must be a list of ground literals", _line(w, "facts"))
        fl = []
    for f in fl:
        try:
            lit = parse_literal(str(f), str(c.path), _line(w, "facts"))
        except FormatError as exc:
            c.from_format_error(exc)
            continue
        if not lit.is_ground or lit.negated:
            c.error(f"fact {f!r} must be a positive ground literal", _line(w, "facts"))
            continue
        facts.append(lit)
    st = w.get("supertypes") or {}
    if not isinstance(st, Mapping) or not all(
        isinstance(k, str) and isinstance(v, str) for k, v in st.items()
    ):
        c.error(
            f"world.supertypes must be a mapping {{SUBTYPE: SUPERTYPE}} of type names, got "
            f"{show(st)}",
            _line(w, "supertypes"),
        )
        st = {}
    for sub in st:
        cycle = [sub]
        while cycle[-1] in st and st[cycle[-1]] not in cycle:
            cycle.append(st[cycle[-1]])
        # a cycle through ``sub``, reported once: at its smallest type
        if cycle[-1] in st and st[cycle[-1]] == sub and sub == min(cycle):
            c.error(
                f"world.supertypes form a cycle: {' -> '.join([*cycle, sub])}",
                _line(st, sub) or _line(w, "supertypes"),
            )
    names = [o.name for o in objects] + list(places)
    dup = {n for n in names if names.count(n) > 1}
    for n in sorted(dup):
        c.error(f"{n!r} is both an object and a place", _line(w))
    return WorldSpec(tuple(objects), places, tuple(facts), {str(k): str(v) for k, v in st.items()})


def _size(v: Any) -> dict[str, float] | None:
    if v is None:
        return {}
    if isinstance(v, Mapping):
        items = list(v.items())
    elif isinstance(v, list | tuple) and len(v) <= 3:
        items = list(zip(("length", "width", "height"), v, strict=False))
    else:
        return None
    out: dict[str, float] = {}
    for k, x in items:
        if isinstance(x, bool) or not isinstance(x, int | float) or not (0 < x < 1e3):
            return None
        out[str(k)] = float(x)
    return out


def _humans(h: Any, c: _Checker, line: int | None, domain: Domain | None) -> list[HumanSpec]:
    out: list[HumanSpec] = []
    if h is None:
        if domain is not None:  # every human agent of the domain is a passive operator
            out = [HumanSpec(a.name) for a in domain.agents.values() if a.is_human]
        return out
    if not isinstance(h, list):
        c.error("humans must be a list of {name, profile, speed}", line)
        return out
    seen: dict[str, int | None] = {}
    for i, hd in enumerate(h):
        if not isinstance(hd, Mapping) or "name" not in hd:
            c.error(f"humans #{i + 1}: needs a name (a human agent of the domain)", line)
            continue
        ln = _line(hd)
        name = str(hd["name"])
        got = c.fields(hd, HUMAN_DECL, f"operator {show(name)}")
        if name in seen:
            c.error(
                f"operator {show(name)}: listed twice under humans (one entry per human agent; "
                f"the first is at line {seen[name]})",
                ln,
            )
        seen[name] = ln
        profile = got.get("profile", "passive")
        speed = got.get("speed", 1.0)
        if domain is not None:
            agent = domain.agents.get(name)
            if agent is None:
                c.error(
                    f"operator {name!r}: undeclared agent (declare it under domain agents with "
                    "kind: human)",
                    ln,
                )
            elif not agent.is_human:
                c.error(f"operator {name!r}: agent {name!r} is a robot, not a human", ln)
        out.append(HumanSpec(name, profile, float(speed)))
    return out


def _attach_actions(graph: HierarchicalGraph, spec: Any, c: _Checker, line: int | None) -> None:
    """``hyperarc_actions: {GRAPH/HYPERARC: [actions]}``: action lists for hyper-arcs of graph
    files that have none (ANDOR text). GRAPH is the graph's key or name; both parts may be
    glob patterns (``RollerAssembly/h*``)."""
    if not isinstance(spec, Mapping):
        c.error("hyperarc_actions must be a mapping {GRAPH/HYPERARC: [actions]}", line)
        return
    for pattern, actions in spec.items():
        ln = _line(spec, pattern)
        if not isinstance(actions, list) or not all(isinstance(a, str) for a in actions):
            c.error(f"hyperarc_actions {pattern!r}: a list of actions such as 'screw(?a, ?b)'", ln)
            continue
        hits = 0
        for hyperarcs, hname in _matching(graph, str(pattern), "hyperarcs"):
            h = hyperarcs[hname]
            hyperarcs[hname] = replace(h, actions=tuple(actions), line=h.line)
            hits += 1
        if not hits:
            c.error(f"hyperarc_actions {pattern!r} matches no hyper-arc of the graph", ln)


def _matching(graph: HierarchicalGraph, pattern: str, elements: str) -> list[tuple[Any, str]]:
    """The (table, name) of every hyper-arc or node (``elements``) a ``GRAPH/NAME`` glob pattern
    matches; GRAPH is a graph's key or name, ``*`` when the pattern has no ``/``."""
    gpat, _, epat = pattern.rpartition("/")
    gpat = gpat or "*"
    return [
        (table, name)
        for key, g in graph.graphs.items()
        if fnmatch.fnmatchcase(key, gpat) or fnmatch.fnmatchcase(g.name, gpat)
        for table in (getattr(g, elements),)
        for name in table
        if fnmatch.fnmatchcase(name, epat)
    ]


def _attach_states(graph: HierarchicalGraph, spec: Any, c: _Checker, line: int | None) -> None:
    """``node_states: {GRAPH/NODE: formula}``: state formulas S(n) for nodes of graph files
    that state none (ANDOR text), e.g. so that a grounding passes through a transition
    (M1/M2, paper 000 eqs. 15-16; ``docs/andor.md``). GRAPH is the graph's key or name; both
    parts may be glob patterns. The transitions are checked again with the new formulas."""
    if not isinstance(spec, Mapping):
        c.error("node_states must be a mapping {GRAPH/NODE: formula}", line)
        return
    changed = False
    for pattern, text in spec.items():
        ln = _line(spec, pattern)
        if not isinstance(text, str):
            c.error(f"node_states {pattern!r}: a formula such as 'loose(?s) & spare(?s)'", ln)
            continue
        try:
            formula = parse_conjunction(text, str(c.path), ln)
        except FormatError as e:
            c.error(f"node_states {pattern!r}: {e.message}", ln)
            continue
        hits = 0
        for nodes, nname in _matching(graph, str(pattern), "nodes"):
            nodes[nname] = replace(nodes[nname], formula=formula, line=nodes[nname].line)
            hits += 1
        if not hits:
            c.error(f"node_states {pattern!r} matches no node of the graph", ln)
        changed = changed or bool(hits)
    if changed:
        try:
            graph.validate()  # the literals of every transition, with the new formulas
        except FormatError as e:
            c.error(f"node_states: {e}", line)


# ------------------------------------------------------------------------------ semantics --
def _check_semantics(
    graph: HierarchicalGraph,
    domain: Domain,
    domain_doc: Any,
    domain_src: Path,
    world: WorldSpec,
    humans: list[HumanSpec],
    c: _Checker,
) -> None:
    # types the scenario declares: objects, places, agents, supertypes
    declared: set[str] = {"agent", "place", *c.types}
    for o in world.objects:
        declared.add(o.type)
    for a in domain.agents.values():
        declared.update(a.types)
        declared.add(a.name)
    declared.update(world.supertypes)
    declared.update(world.supertypes.values())
    # ... and the types the domain needs
    needed: set[str] = set()
    schemas: list[tuple[str, ActionSchema]] = [
        *(("action", s) for s in domain.actions.values()),
        *(("process", s) for s in domain.processes.values()),
    ]
    key_line: dict[tuple[str, str], int | None] = {}
    for what, s in schemas:
        block = (domain_doc or {}).get(f"{what}es" if what == "process" else "actions") or {}
        sd = block.get(s.name) if isinstance(block, Mapping) else None
        key_line[(what, s.name)] = _line(block, s.name) if sd is not None else s.line
        ln = _line(sd, "parameters") if sd is not None else s.line
        for var, typ in s.parameters:
            needed.add(typ)
            if typ not in declared:
                c.error(
                    f"{what} {s.name!r}: parameter {var} of undeclared type {typ!r} (no object, "
                    "place, agent or supertype has it)",
                    ln,
                    domain_src,
                )
    for o in world.objects:
        chain = _chain(o.type, world.supertypes)
        if not any(t in needed for t in chain) and not _type_used(o.type, graph, domain):
            c.error(
                f"object {o.name!r} of unknown type {o.type!r} (the domain's types: "
                f"{', '.join(sorted(needed - {'agent'})) or 'none'}; or map it under "
                "world.supertypes)",
                _object_line(c, o.name),
            )
    # hyper-arcs: known actions, some agent able to do each
    for key in graph.used_keys():
        g = graph.graphs[key]
        for h in g.hyperarcs.values():
            src = g.source or c.path
            for text in h.actions:
                try:
                    lit = parse_literal(text, str(src), h.line)
                except FormatError as exc:
                    c.from_format_error(exc)
                    continue
                schema = domain.actions.get(lit.predicate)
                if schema is None:
                    c.error(
                        f"hyper-arc {h.name!r}: unknown action {lit.predicate!r} (actions: "
                        f"{', '.join(sorted(domain.actions)) or 'none'})",
                        h.line,
                        src,
                    )
                    continue
                if len(lit.args) != len(schema.parameters):
                    c.error(
                        f"hyper-arc {h.name!r}: {text!r}: {schema.name} takes "
                        f"{len(schema.parameters)} arguments, got {len(lit.args)}",
                        h.line,
                        src,
                    )
                    continue
                for term in lit.args:
                    known = _constants(world, domain) | c.names
                    if not term.startswith("?") and term not in known:
                        c.error(
                            f"hyper-arc {h.name!r}: {text!r}: {term!r} is no object, place or "
                            "agent of the scenario",
                            h.line,
                            src,
                        )
                if not _someone_can(schema, lit, domain):
                    c.error(
                        f"hyper-arc {h.name!r}: no declared agent can do {text!r} "
                        f"(agents: {', '.join(domain.agents) or 'none'})",
                        h.line,
                        src,
                    )
            for pname in _node_processes(g):
                if pname not in domain.processes:
                    c.error(
                        f"graph {key!r}: unknown process {pname!r} (processes: "
                        f"{', '.join(sorted(domain.processes)) or 'none'})",
                        g.root_line,
                        src,
                    )
    # predicates that can never become true (warning)
    makeable: set[str] = {lit.predicate for lit in world.facts}
    for _, s in schemas:
        makeable.update(lit.predicate for lit in s.add)
    for o in world.objects:
        makeable.update(_chain(o.type, world.supertypes))
    makeable.update(declared)
    for t in c.types:
        makeable.update(_chain(t, world.supertypes))
    reported: set[str] = set()

    def need(lits: Iterable[Literal], where: str, line: int | None, src: Any) -> None:
        for lit in lits:
            if lit.negated or lit.predicate in makeable or lit.predicate in reported:
                continue
            reported.add(lit.predicate)
            c.warn(
                f"{where}: predicate {lit.predicate!r} is in no fact and no effect: "
                f"{lit} can never become true",
                line,
                src,
            )

    for key in graph.used_keys():
        g = graph.graphs[key]
        for n in g.nodes.values():
            if n.formula:
                need(n.formula, f"node {n.name!r}", n.line, g.source or c.path)
    for what, s in schemas:
        ln = key_line.get((what, s.name))
        need(
            s.pre,
            f"{what} {s.name!r}: precondition",
            _line_in(s, "pre", domain_doc, what) or ln,
            domain_src,
        )
        need(
            s.until,
            f"{what} {s.name!r}: end condition",
            _line_in(s, "until", domain_doc, what) or ln,
            domain_src,
        )

    _check_parents_reached(graph, domain, world, c)


def _check_parents_reached(
    graph: HierarchicalGraph, domain: Domain, world: WorldSpec, c: _Checker
) -> None:
    """A hyper-arc whose actions never make its parent's state formula true (see
    :mod:`flexhrc.scenario.achieve`): the parent is never met, the run ends in a deadlock."""
    from flexhrc.scenario.achieve import never_achieved

    types: dict[str, set[str]] = {}
    for o in world.objects:
        types.setdefault(o.name, set()).update(_chain(o.type, world.supertypes))
    for p in world.places:
        types.setdefault(p, set()).add("place")
    for a in domain.agents.values():
        types.setdefault(a.name, set()).update(
            {a.name, a.kind, "agent", *(t for x in a.types for t in _chain(x, world.supertypes))}
        )
    facts = [*world.facts, *(Literal(t, (name,)) for name, ts in types.items() for t in ts)]
    for fault in never_achieved(graph, domain, facts, {k: frozenset(v) for k, v in types.items()}):
        c.error(fault.message, fault.line, fault.source or c.path)


def _check_kind_targets(domain: Domain, domain_doc: Any, src: Any, c: _Checker) -> None:
    """Warn about a robot action whose kind moves the arm to a target its parameters cannot
    name (the kinematic simulator would time it analytically; see flexhrc.taskmanager.kinds)."""
    agent_types = {"agent"}
    for a in domain.agents.values():
        agent_types.update((a.name, a.kind, *a.types))
    for s in domain.actions.values():
        kind = find_action_kind(s.kind)
        if kind is None or not kind.motion or s.target:
            continue
        if all(a.is_human for a in domain.capable(s)):
            continue
        free = [v for v, t in s.parameters if t not in agent_types and v != s.agents.variable]
        can = {"object": bool(s.carries or free), "place": bool(s.moves_to or len(free) >= 2)}
        for step in kind.motion:
            if step.target and not step.optional and not any(can[r] for r in step.target):
                role = "a place to go to" if step.target[0] == "place" else "an object to aim at"
                c.warn(
                    f"action {s.name!r}: kind {s.kind!r} needs {role} but no parameter names "
                    "one (add it and name it with target: [?object, ?place]); its robot motion "
                    "is timed analytically until then",
                    _line_in(s, "kind", domain_doc, "action") or s.line,
                    src,
                )
                break


def _line_in(s: ActionSchema, key: str, domain_doc: Any, what: str) -> int | None:
    block = (domain_doc or {}).get(f"{what}es" if what == "process" else "actions") or {}
    sd = block.get(s.name) if isinstance(block, Mapping) else None
    return _line(sd, key) if sd is not None and key in sd else None


def _object_line(c: _Checker, name: str) -> int | None:
    from flexhrc.representation.formats.yaml_format import read_yaml

    try:
        doc = read_yaml(c.path)
        return _line(doc["world"]["objects"], name)
    except (FormatError, KeyError, TypeError):
        return None


def _chain(typ: str, supertypes: Mapping[str, str]) -> list[str]:
    chain = [typ]
    while chain[-1] in supertypes and supertypes[chain[-1]] not in chain:
        chain.append(supertypes[chain[-1]])
    return chain


def _type_used(typ: str, graph: HierarchicalGraph, domain: Domain) -> bool:
    """A type used as a unary predicate in a node formula or a precondition counts as known."""
    for key in graph.used_keys():
        for n in graph.graphs[key].nodes.values():
            if n.formula and any(lit.predicate == typ and len(lit.args) == 1 for lit in n.formula):
                return True
    for s in [*domain.actions.values(), *domain.processes.values()]:
        if any(lit.predicate == typ and len(lit.args) == 1 for lit in s.pre):
            return True
    return False


def _constants(world: WorldSpec, domain: Domain) -> set[str]:
    return {o.name for o in world.objects} | set(world.places) | set(domain.agents)


def _someone_can(schema: ActionSchema, lit: Literal, domain: Domain) -> bool:
    spec = schema.agents
    if spec.mode in ("single", "joint"):
        return all(n in domain.agents for n in spec.names) and bool(spec.names)
    idx = schema.variables.index(str(spec.variable))
    term = lit.args[idx]
    if not term.startswith("?"):
        agent = domain.agents.get(term)
        typ = schema.parameters[idx][1]
        return agent is not None and (typ == "agent" or typ in agent.types or typ == agent.name)
    return bool(domain.capable(schema))


def _node_processes(g: AndOrGraph) -> list[str]:
    out = []
    for n in g.nodes.values():
        for p in n.processes:
            try:
                out.append(parse_literal(p).predicate)
            except FormatError:
                out.append(p)
    return out
