"""The layering of flexhrc, declared once and read back from the code (docs/architecture.md).

:data:`FLOORS` is the one place that says which package stands on which floor. The rule a
contribution keeps (``docs/architecture.md``, tested by ``tests/test_architecture.py``):

* a package imports only packages on lower floors, or a package on its own floor where
  :data:`SAME_FLOOR` allows it — whether the import runs at module level, inside a function or
  under ``if TYPE_CHECKING`` (a lazy import is still a dependency; it only runs later);
* no two modules import each other, directly or round a longer circle, counting every import.

The import graph comes from the source with :mod:`ast` (nothing is imported, so optional extras
need not be installed): ``import flexhrc.a.b`` is an edge to ``flexhrc.a.b``;
``from flexhrc.a import b`` an edge to the submodule ``flexhrc.a.b`` when there is one and to
``flexhrc.a`` otherwise; relative imports are resolved; ``importlib.import_module("flexhrc.x")``
with a literal name counts like an import statement in its place. A name built at run time (an
f-string) cannot be read and does not count; a compiled module (``_andor_fast``) imports nothing.

    python scripts/architecture.py --write    # rewrite the diagram between the markers
    python scripts/architecture.py --check    # exit 1: stale diagram, upward import or cycle
    python scripts/architecture.py --print    # the diagram on stdout

A development tool, not part of the package: standard library only, it runs from a checkout
without installing anything, and ``tests/test_architecture.py`` loads it from here.
"""

from __future__ import annotations

import argparse
import ast
import functools
import sys
from collections import defaultdict
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

ROOT = "flexhrc"

#: package (the first name below ``flexhrc``; ``__init__`` is the package's own ``__init__.py``)
#: -> floor. Derived from the real imports; a new package gets a line here.
FLOORS: dict[str, int] = {
    # the ground: errors, checked I/O, JSON lines, the event catalogue
    "errors": 0,
    "files": 0,
    "jsonl": 0,
    "events": 0,
    "__init__": 0,
    # terms and literals; the publish/subscribe contract
    "logic": 1,
    "transport": 1,
    "knowledge": 2,
    "representation": 3,
    "perception": 3,
    "taskmanager": 4,
    "behavior": 4,
    "action": 5,
    # the one loop (the engine) stands below the scenario that configures it
    "cell": 6,
    # the one type of a task, its files, the ready-made tasks (builtin), the simulator choice
    "scenario": 7,
    # the front ends around the cell; planning ahead (CP-SAT) beside them, above the scenario
    "planning": 8,
    "sensing": 8,
    "web": 8,
    "ros2": 8,
    # the application layer: each command as a library call, config in, report out
    "app": 9,
    "cli": 10,
    "__main__": 10,
}

#: (importer, imported) pairs on one floor that may depend on each other, in this direction only.
SAME_FLOOR: frozenset[tuple[str, str]] = frozenset(
    {
        ("files", "errors"),
        ("jsonl", "errors"),
        ("jsonl", "files"),
        ("events", "errors"),
        ("__init__", "errors"),
        ("__main__", "cli"),
    }
)

#: What each floor is, for the diagram.
FLOOR_NAMES: dict[int, str] = {
    0: "utilities",
    1: "logic, transport contract",
    2: "knowledge base",
    3: "task representation, perception",
    4: "Task Manager, behaviour networks",
    5: "action level (robot, controller, kinematic simulator)",
    6: "the cell: the one loop (the engine)",
    7: "scenarios: one type, files, ready-made tasks, loaders, run",
    8: "front ends",
    9: "the application layer: a command as config -> report",
    10: "the command line",
}

BEGIN_MARK = "<!-- BEGIN GENERATED: python scripts/architecture.py --write -->"
END_MARK = "<!-- END GENERATED -->"

TOP, FUNCTION, TYPE_CHECKING = "top", "function", "type-checking"


@dataclass(frozen=True)
class Import:
    """One import of a flexhrc module by another, as written in the source."""

    source: str  # importing module, e.g. "flexhrc.cli.behave"
    target: str  # imported module, e.g. "flexhrc.cli.behave_common"
    kind: str  # TOP, FUNCTION or TYPE_CHECKING
    line: int

    def where(self, pkg_dir: Path | None = None) -> str:
        """``src/flexhrc/cli/behave.py:27``: where the import is written."""
        path = modules(pkg_dir)[self.source]
        base = (pkg_dir or package_dir()).parent.parent
        shown = path.relative_to(base) if path.is_relative_to(base) else path
        return f"{shown.as_posix()}:{self.line}"


def package_dir() -> Path:
    """The ``flexhrc`` source directory of the checkout this script belongs to."""
    return Path(__file__).resolve().parent.parent / "src" / "flexhrc"


def _name(path: Path, pkg_dir: Path) -> str:
    parts = list(path.relative_to(pkg_dir).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join([ROOT, *parts])


@functools.cache
def _scan(pkg_dir: Path) -> tuple[dict[str, Path], tuple[Import, ...]]:
    known = {_name(path, pkg_dir): path for path in sorted(pkg_dir.rglob("*.py"))}
    compiled = {_name(path, pkg_dir) for path in pkg_dir.rglob("*.c")}
    found: list[Import] = []
    for module, path in known.items():
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        finder = _Finder(module, path.name == "__init__.py", known, compiled)
        finder.visit(tree)
        found.extend(finder.found)
    return known, tuple(found)


def modules(pkg_dir: Path | None = None) -> dict[str, Path]:
    """Every Python module of the package: dotted name -> file."""
    return dict(_scan(pkg_dir or package_dir())[0])


def imports(pkg_dir: Path | None = None) -> tuple[Import, ...]:
    """Every import between flexhrc modules, module by module in source order."""
    return _scan(pkg_dir or package_dir())[1]


def package_of(module: str) -> str:
    """``flexhrc.cli.behave`` -> ``cli``; ``flexhrc`` itself -> ``__init__``."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


class _Finder(ast.NodeVisitor):
    """Collects imports with the context they run in."""

    def __init__(
        self, module: str, is_package: bool, known: Mapping[str, Path], compiled: set[str]
    ) -> None:
        self.module = module
        self.is_package = is_package
        self.known = known
        self.compiled = compiled
        self.kind = TOP
        self.found: list[Import] = []

    def _add(self, target: str, line: int) -> None:
        if target != ROOT and not target.startswith(ROOT + "."):
            return
        # A compiled module (``_andor_fast``) is a leaf: it imports nothing of flexhrc.
        if target in self.compiled:
            return
        # A name that is no module (a typo, a module gone) lands on the nearest one above it.
        while target not in self.known and "." in target:
            target = target.rsplit(".", 1)[0]
        found = Import(self.module, target, self.kind, line)
        if target != self.module and found not in self.found:
            self.found.append(found)

    def _within(self, kind: str, nodes: Iterable[ast.AST]) -> None:
        saved, self.kind = self.kind, kind if self.kind == TOP else self.kind
        for node in nodes:
            self.visit(node)
        self.kind = saved

    def visit_FunctionDef(self, node: ast.FunctionDef) -> None:
        self._within(FUNCTION, [*node.decorator_list, *node.body])

    def visit_AsyncFunctionDef(self, node: ast.AsyncFunctionDef) -> None:
        self._within(FUNCTION, [*node.decorator_list, *node.body])

    def visit_Lambda(self, node: ast.Lambda) -> None:
        self._within(FUNCTION, [node.body])

    def visit_If(self, node: ast.If) -> None:
        if _is_type_checking(node.test):
            self._within(TYPE_CHECKING, node.body)
            for child in node.orelse:
                self.visit(child)
        else:
            self.generic_visit(node)

    def visit_Import(self, node: ast.Import) -> None:
        for alias in node.names:
            self._add(alias.name, node.lineno)

    def visit_ImportFrom(self, node: ast.ImportFrom) -> None:
        if node.level:
            # Relative: `from . import x` in a package's __init__ means the package itself.
            anchor = self.module.split(".")
            drop = node.level - (1 if self.is_package else 0)
            base = ".".join(anchor[: len(anchor) - drop] if drop else anchor)
            origin = f"{base}.{node.module}" if node.module else base
        else:
            origin = node.module or ""
        for alias in node.names:
            candidate = f"{origin}.{alias.name}"
            self._add(candidate if candidate in self.known else origin, node.lineno)

    def visit_Call(self, node: ast.Call) -> None:
        func = node.func
        name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
        if (
            name == "import_module"
            and node.args
            and isinstance(node.args[0], ast.Constant)
            and isinstance(node.args[0].value, str)
        ):
            self._add(node.args[0].value, node.lineno)
        self.generic_visit(node)


def unplaced(pkg_dir: Path | None = None) -> list[str]:
    """Packages of the source that :data:`FLOORS` does not place."""
    pkg_dir = pkg_dir or package_dir()
    return sorted({package_of(m) for m in modules(pkg_dir)} - FLOORS.keys())


def upward(found: Iterable[Import]) -> list[Import]:
    """Imports that break the floors: to a higher floor, or sideways without leave."""
    broken = []
    for imp in found:
        a, b = package_of(imp.source), package_of(imp.target)
        if a == b or a not in FLOORS or b not in FLOORS:
            continue
        if FLOORS[b] > FLOORS[a] or (FLOORS[b] == FLOORS[a] and (a, b) not in SAME_FLOOR):
            broken.append(imp)
    return broken


def cycles(edges: Mapping[str, Iterable[str]]) -> list[list[str]]:
    """Strongly connected components of more than one node (Tarjan), each sorted, in order."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    found: list[list[str]] = []
    nodes = sorted(set(edges) | {t for ts in edges.values() for t in ts})

    # Iterative, so a deep chain of imports cannot hit the recursion limit.
    for root in nodes:
        if root in index:
            continue
        work: list[tuple[str, Iterator[str]]] = [(root, iter(sorted(edges.get(root, ()))))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(edges.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return sorted(found)


def module_cycles(found: Iterable[Import]) -> list[list[str]]:
    """Circles of modules importing each other, counting every kind of import."""
    edges: dict[str, set[str]] = defaultdict(set)
    for imp in found:
        edges[imp.source].add(imp.target)
    return cycles(edges)


def package_cycles(found: Iterable[Import]) -> list[list[str]]:
    """Circles of packages importing each other, counting every kind of import."""
    edges: dict[str, set[str]] = defaultdict(set)
    for imp in found:
        a, b = package_of(imp.source), package_of(imp.target)
        if a != b:
            edges[a].add(b)
    return cycles(edges)


def _lines(path: Path) -> int:
    with path.open("rb") as handle:
        return sum(1 for _ in handle)


def _size(lines: int) -> str:
    return "<0.1k" if lines < 50 else f"{lines / 1000:.1f}k"


def diagram(pkg_dir: Path | None = None, width: int = 100) -> str:
    """The packages by floor, highest first, with their size and the packages they import.

    Sizes are rounded to a tenth of a thousand lines and the edges carry no counts, so the
    picture changes when the structure does, not with every edit.
    """
    pkg_dir = pkg_dir or package_dir()
    size: dict[str, int] = defaultdict(int)
    count: dict[str, int] = defaultdict(int)
    for module, path in modules(pkg_dir).items():
        size[package_of(module)] += _lines(path)
        count[package_of(module)] += 1
    kinds: dict[str, dict[str, set[str]]] = defaultdict(lambda: defaultdict(set))
    for imp in imports(pkg_dir):
        a, b = package_of(imp.source), package_of(imp.target)
        if a != b:
            kinds[a][b].add(imp.kind)

    def shown(pkg: str) -> str:
        return pkg + ("/" if (pkg_dir / pkg).is_dir() else ".py")

    def edge(target: str, how: set[str]) -> str:
        if TOP in how:
            return target
        return f"({target})" if FUNCTION in how else f"[{target}]"

    def floor_key(pkg: str) -> int:
        return FLOORS.get(pkg, max(FLOORS.values()) + 1)  # unplaced: on top, as "floor ?"

    out: list[str] = []
    for floor in sorted({floor_key(p) for p in count}, reverse=True):
        if out:
            out.append("")
        if floor in FLOORS.values():
            out.append(f"floor {floor:<3} {FLOOR_NAMES.get(floor, '')}".rstrip())
        else:
            out.append("floor ?   (not in FLOORS)")
        for pkg in sorted(p for p in count if floor_key(p) == floor):
            noun = "module " if count[pkg] == 1 else "modules"
            head = f"{'':10}{shown(pkg):<16}{count[pkg]:>3} {noun} {_size(size[pkg]):>6} lines  -> "
            targets = sorted(kinds[pkg], key=lambda t: (-floor_key(t), t))
            words = [edge(t, kinds[pkg][t]) for t in targets] or ["-"]
            line = head
            for i, word in enumerate(words):
                word += "," if i < len(words) - 1 else ""
                if len(line) + len(word) > width and len(line) > len(head):
                    out.append(line.rstrip())
                    line = " " * len(head)
                line += word + " "
            out.append(line.rstrip())
    out += [
        "",
        "-> name    imported at module level",
        "-> (name)  imported only inside functions (on demand: optional extras, a fast --help)",
        "-> [name]  imported only under TYPE_CHECKING",
        "Every kind counts for the rule: only lower floors, no circles.",
    ]
    return "\n".join(out)


def render(text: str, pkg_dir: Path | None = None) -> str:
    """``text`` (the architecture page) with a fresh diagram between the markers."""
    begin, end = text.find(BEGIN_MARK), text.find(END_MARK)
    if begin < 0 or end < begin:
        raise ValueError(f"the page lacks the markers {BEGIN_MARK!r} ... {END_MARK!r}")
    block = f"{BEGIN_MARK}\n```text\n{diagram(pkg_dir)}\n```\n"
    return text[:begin] + block + text[end:]


def problems(pkg_dir: Path | None = None) -> list[str]:
    """Every break of the rule, one line each (empty when the layering holds)."""
    found = imports(pkg_dir)
    lines = [
        f"package {pkg!r} is not in the layer table: add it to FLOORS in scripts/architecture.py"
        for pkg in unplaced(pkg_dir)
    ]
    for imp in upward(found):
        a, b = package_of(imp.source), package_of(imp.target)
        lines.append(
            f"{imp.where(pkg_dir)}: {a} (floor {FLOORS[a]}) imports {imp.target} "
            f"({b}, floor {FLOORS[b]}; {imp.kind} import)"
        )
    lines += [f"modules import each other: {' <-> '.join(c)}" for c in module_cycles(found)]
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="scripts/architecture.py",
        description="Check the layering of flexhrc and keep the diagram of "
        "docs/architecture.md up to date.",
    )
    default_doc = package_dir().parent.parent / "docs" / "architecture.md"
    parser.add_argument("--doc", type=Path, default=default_doc, help="the page (%(default)s)")
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--write", action="store_true", help="rewrite the diagram in the page")
    group.add_argument(
        "--check", action="store_true", help="exit 1 when the page is stale or the rule broken"
    )
    group.add_argument("--print", action="store_true", help="print the diagram")
    args = parser.parse_args(argv)
    if args.print:
        sys.stdout.write(diagram() + "\n")
        return 0
    try:
        text = args.doc.read_text(encoding="utf-8")
        fresh = render(text)
    except (OSError, ValueError) as exc:
        print(f"{args.doc}: {exc}", file=sys.stderr)
        return 2
    if args.write:
        if fresh != text:
            args.doc.write_text(fresh, encoding="utf-8")
            print(f"{args.doc}: diagram rewritten")
        return 0
    broken = problems()
    for line in broken:
        print(line, file=sys.stderr)
    if fresh != text:
        print(
            f"{args.doc}: the diagram is stale; run: python scripts/architecture.py --write",
            file=sys.stderr,
        )
        return 1
    return 1 if broken else 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
