"""The compact task structure: THEN / AND / OR goal nodes over behaviour leaves (paper 002, III-B).

A task is an N-ary tree. Goal nodes encode the execution constraints:

* ``THEN`` — sequence: the children are achieved one after the other, in order;
* ``AND``  — no ordering: every child is achieved, in any order (or in parallel);
* ``OR``   — alternatives: exactly one child is achieved.

Leaves are behaviour nodes (here: pick-and-place of the object with the same name). The same tree
is both the representation and, once turned into a
:class:`~flexhrc.behavior.network.BehaviorNetwork`, the controller.

The textual form is the paper's prefix encoding, e.g. Fig. 1::

    (THEN a (AND (THEN b c) (OR d e (THEN f g))))

(commas between children are accepted, as printed in the paper). Goal nodes are named after their
type and pre-order rank, ``THEN_1``, ``AND_1``, ``THEN_2`` … like the paper's figures.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

from flexhrc.errors import FormatError

THEN = "THEN"
AND = "AND"
OR = "OR"
BEHAVIOR = "BEHAVIOR"
GOAL_KINDS = (THEN, AND, OR)

_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_\-.]*\Z")

#: Deepest nesting of goals a task may have. Every algorithm on task trees (parsing, the
#: validator, rendering, compiling) recurses once per level; the limit keeps that far from
#: Python's recursion limit and gives one clear error instead of a RecursionError.
MAX_DEPTH = 200


@dataclass(frozen=True)
class TaskNode:
    """One node of a task tree: a goal (THEN/AND/OR with children) or a behaviour leaf."""

    kind: str
    name: str
    children: tuple[TaskNode, ...] = ()
    line: int | None = field(default=None, compare=False)
    column: int | None = field(default=None, compare=False)

    @property
    def is_goal(self) -> bool:
        return self.kind != BEHAVIOR

    def walk(self) -> Iterator[TaskNode]:
        """Pre-order traversal (parent before children, children left to right)."""
        stack = [self]
        while stack:
            node = stack.pop()
            yield node
            stack.extend(reversed(node.children))

    def behaviors(self) -> list[str]:
        return [n.name for n in self.walk() if n.kind == BEHAVIOR]

    def to_prefix(self) -> str:
        if self.kind == BEHAVIOR:
            return self.name
        return "(" + " ".join([self.kind, *(c.to_prefix() for c in self.children)]) + ")"


@dataclass(frozen=True)
class Task:
    """A validated task tree with unique node names."""

    root: TaskNode
    source: str = "<task>"

    def walk(self) -> Iterator[TaskNode]:
        return self.root.walk()

    @property
    def behaviors(self) -> list[str]:
        """Behaviour (leaf) names in pre-order."""
        return self.root.behaviors()

    @property
    def size(self) -> int:
        return sum(1 for _ in self.walk())

    def to_prefix(self) -> str:
        return self.root.to_prefix()

    def __str__(self) -> str:
        return self.to_prefix()


# ----------------------------------------------------------------------------- building


def build_task(spec: Any, source: str = "<task>") -> Task:
    """Name the goal nodes (``THEN_1`` …) and check the tree; ``spec`` is a nested
    ``(kind, [children], line, column)`` / ``(name, line, column)`` structure from a parser."""
    counters = {k: 0 for k in GOAL_KINDS}
    seen: dict[str, tuple[int | None, int | None]] = {}

    def make(item: Any, depth: int = 0) -> TaskNode:
        if item[0] == BEHAVIOR:
            _, name, line, col = item
            if name.upper() in GOAL_KINDS:
                raise FormatError(
                    _at(f"{name!r} is a goal type, not a behaviour name", col), source, line
                )
            if not _NAME.match(name):
                raise FormatError(_at(f"invalid behaviour name {name!r}", col), source, line)
            if name in seen:
                pl, pc = seen[name]
                raise FormatError(
                    _at(f"behaviour {name!r} appears twice (first at line {pl}, column {pc})", col),
                    source,
                    line,
                )
            seen[name] = (line, col)
            return TaskNode(BEHAVIOR, name, (), line, col)
        kind, children, line, col = item
        if depth >= MAX_DEPTH:
            raise FormatError(_too_deep(col), source, line)
        if not children:
            raise FormatError(_at(f"{kind} goal needs at least one child", col), source, line)
        counters[kind] += 1
        name = f"{kind}_{counters[kind]}"
        return TaskNode(kind, name, tuple(make(c, depth + 1) for c in children), line, col)

    root = make(spec)
    goal_names = {n.name for n in root.walk() if n.is_goal}
    clash = goal_names & set(seen)
    if clash:
        name = sorted(clash)[0]
        line, col = seen[name]
        raise FormatError(
            _at(f"behaviour name {name!r} clashes with a goal node name", col), source, line
        )
    return Task(root, source)


def _too_deep(column: int | None) -> str:
    return _at(
        f"goals nested more than {MAX_DEPTH} levels deep; flatten the task "
        "(e.g. (THEN a (THEN b c)) is (THEN a b c))",
        column,
    )


def _at(message: str, column: int | None) -> str:
    return f"column {column}: {message}" if column is not None else message


# ----------------------------------------------------------------------------- prefix form

_TOKEN = re.compile(r"\s+|,|#[^\n]*|\(|\)|[^\s(),#]+")


def parse_prefix(text: str, source: str = "<task>") -> Task:
    """Parse the prefix form ``(THEN a (AND b c))``; errors name the line and column."""
    tokens: list[tuple[str, int, int]] = []
    line, line_start = 1, 0
    for m in _TOKEN.finditer(text):
        tok = m.group()
        col = m.start() - line_start + 1
        if tok.isspace() or tok == "," or tok.startswith("#"):
            nl = tok.count("\n")
            if nl:
                line += nl
                line_start = m.start() + tok.rfind("\n") + 1
            continue
        tokens.append((tok, line, col))
    if not tokens:
        raise FormatError("empty task: expected e.g. (THEN a (AND b c))", source, 1)
    pos = 0

    def parse_item(depth: int) -> Any:
        nonlocal pos
        tok, ln, col = tokens[pos]
        if tok == ")":
            raise FormatError(f"column {col}: unexpected ')'", source, ln)
        if tok != "(":
            pos += 1
            return (BEHAVIOR, tok, ln, col)
        if depth >= MAX_DEPTH:
            raise FormatError(_too_deep(col), source, ln)
        pos += 1
        if pos >= len(tokens):
            raise FormatError(f"column {col}: '(' is never closed", source, ln)
        kind_tok, kl, kc = tokens[pos]
        if kind_tok.upper() not in GOAL_KINDS:
            raise FormatError(
                f"column {kc}: expected THEN, AND or OR after '(', got {kind_tok!r}", source, kl
            )
        pos += 1
        children: list[TaskNode] = []
        while True:
            if pos >= len(tokens):
                raise FormatError(f"column {col}: '(' is never closed", source, ln)
            if tokens[pos][0] == ")":
                pos += 1
                return (kind_tok.upper(), children, ln, col)
            children.append(parse_item(depth + 1))

    spec = parse_item(0)
    if pos < len(tokens):
        tok, ln, col = tokens[pos]
        raise FormatError(f"column {col}: unexpected {tok!r} after the end of the task", source, ln)
    return build_task(spec, source)


# ----------------------------------------------------------------------------- YAML form


def task_spec_from_yaml_node(node: Any, source: str, depth: int = 0) -> Any:
    """Turn a composed YAML node (``yaml.compose``) into a parser spec, keeping line numbers.

    Accepted shapes: a behaviour name (scalar); a one-key mapping ``{THEN|AND|OR: [children]}``;
    or a scalar holding the prefix form.
    """
    import yaml

    line = node.start_mark.line + 1
    col = node.start_mark.column + 1
    if depth >= MAX_DEPTH:
        raise FormatError(_too_deep(col), source, line)
    if isinstance(node, yaml.ScalarNode):
        value = str(node.value).strip()
        if value.startswith("("):
            sub = parse_prefix(value, source)
            return _spec_of(sub.root, line)
        return (BEHAVIOR, value, line, col)
    if isinstance(node, yaml.MappingNode):
        if len(node.value) != 1:
            raise FormatError(
                "a goal is a mapping with exactly one key (THEN, AND or OR)", source, line
            )
        key, value = node.value[0]
        kind = str(key.value).upper()
        if kind not in GOAL_KINDS:
            raise FormatError(
                f"unknown goal type {key.value!r}; expected THEN, AND or OR",
                source,
                key.start_mark.line + 1,
            )
        if not isinstance(value, yaml.SequenceNode):
            raise FormatError(
                f"{kind} expects a list of children", source, value.start_mark.line + 1
            )
        children = [task_spec_from_yaml_node(v, source, depth + 1) for v in value.value]
        return (kind, children, line, col)
    raise FormatError("expected a behaviour name or a {THEN|AND|OR: [...]} mapping", source, line)


def _spec_of(node: TaskNode, line: int) -> Any:
    if node.kind == BEHAVIOR:
        return (BEHAVIOR, node.name, line, None)
    return (node.kind, [_spec_of(c, line) for c in node.children], line, None)
