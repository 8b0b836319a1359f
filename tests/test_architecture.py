"""The layering of docs/architecture.md holds in the code (issue 19, "the map matches the house").

The floors are declared once, in ``FLOORS`` of ``scripts/architecture.py`` (a development tool,
not part of the package, loaded here from the checkout); the import graph is read from the
source with ``ast``. The second half runs the checker on small made-up packages, to show it
finds what it is meant to find.
"""

from __future__ import annotations

import importlib.util
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
_spec = importlib.util.spec_from_file_location("architecture", ROOT / "scripts" / "architecture.py")
assert _spec is not None and _spec.loader is not None
_layers = importlib.util.module_from_spec(_spec)
sys.modules["architecture"] = _layers  # dataclasses look their module up by name
_spec.loader.exec_module(_layers)
from architecture import (  # noqa: E402
    FLOORS,
    FUNCTION,
    SAME_FLOOR,
    TOP,
    TYPE_CHECKING,
    imports,
    module_cycles,
    package_cycles,
    package_of,
    problems,
    render,
    unplaced,
    upward,
)

DOC = ROOT / "docs" / "architecture.md"
FIX = "python scripts/architecture.py --write"


# ----------------------------------------------------------------------------- flexhrc itself


def test_every_package_is_in_the_layer_table():
    missing = unplaced()
    assert not missing, (
        f"package(s) {missing} not in the layer table: add each to FLOORS in "
        f"scripts/architecture.py (the lowest floor above everything it imports), then run {FIX}"
    )


def test_same_floor_leave_is_between_packages_of_one_floor():
    for a, b in SAME_FLOOR:
        assert FLOORS[a] == FLOORS[b], (a, b)


def test_no_import_climbs_a_floor():
    broken = upward(imports())
    assert not broken, (
        "imports against the floors of scripts/architecture.py (move the code down, or for a "
        "deliberate dependency change FLOORS or SAME_FLOOR there):\n"
    ) + "\n".join(
        f"  {imp.where()}: {package_of(imp.source)} (floor {FLOORS[package_of(imp.source)]}) "
        f"imports {imp.target} (floor {FLOORS[package_of(imp.target)]}, {imp.kind})"
        for imp in broken
    )


def test_no_cycle_between_modules_or_packages():
    found = imports()
    assert module_cycles(found) == [], (
        "modules that import each other (every kind counts): move what they share into a "
        "module both import"
    )
    assert package_cycles(found) == []


def test_every_kind_of_import_is_read():
    # the graph sees lazy and TYPE_CHECKING imports, or the two tests above prove little
    kinds = {imp.kind for imp in imports()}
    assert kinds == {TOP, FUNCTION, TYPE_CHECKING}
    edges = {(imp.source, imp.target, imp.kind) for imp in imports()}
    assert ("flexhrc.cli.behave", "flexhrc.cli.behave_team", FUNCTION) in edges
    assert ("flexhrc.transport", "flexhrc.transport.zenoh", TYPE_CHECKING) in edges


def test_the_diagram_in_the_docs_is_up_to_date():
    text = DOC.read_text(encoding="utf-8")
    assert render(text) == text, f"docs/architecture.md: the package diagram is stale; run: {FIX}"


def test_the_command_checks_and_rewrites(tmp_path, capsys):
    page = tmp_path / "architecture.md"
    page.write_text(
        f"# A\n\nbefore\n\n{_layers.BEGIN_MARK}\nold picture\n{_layers.END_MARK}\n\nafter\n"
    )
    assert _layers.main(["--check", "--doc", str(page)]) == 1
    assert FIX in capsys.readouterr().err
    assert _layers.main(["--write", "--doc", str(page)]) == 0
    text = page.read_text()
    assert "old picture" not in text and "floor 0" in text
    assert text.startswith("# A\n\nbefore\n\n") and text.endswith("\nafter\n")
    # fresh now: the exit code says whether the rule holds (the tests above say where not)
    assert _layers.main(["--check", "--doc", str(page)]) == (1 if problems() else 0)
    page.write_text("no markers\n")
    assert _layers.main(["--check", "--doc", str(page)]) == 2
    assert "lacks the markers" in capsys.readouterr().err


# ----------------------------------------------------------------------------- the checker


def _package(tmp_path: Path, files: dict[str, str]) -> Path:
    pkg = tmp_path / "src" / "flexhrc"
    for name, source in {"__init__.py": "", **files}.items():
        path = pkg / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(source))
    return pkg


def test_checker_finds_upward_imports_of_every_kind(tmp_path):
    pkg = _package(
        tmp_path,
        {
            "logic/__init__.py": "",
            "logic/terms.py": """\
                from typing import TYPE_CHECKING

                from flexhrc.errors import FlexhrcError

                if TYPE_CHECKING:
                    from flexhrc.knowledge.base import KnowledgeBase

                def later():
                    import flexhrc.cli.main
                    from ..taskmanager import manager
                """,
            "errors.py": "",
            "knowledge/__init__.py": "",
            "knowledge/base.py": "from flexhrc.logic.terms import later\n",
            "taskmanager/__init__.py": "",
            "taskmanager/manager.py": "",
            "cli/__init__.py": "",
            "cli/main.py": "import importlib\nimportlib.import_module('flexhrc.logic')\n",
        },
    )
    found = imports(pkg)
    assert sorted((i.target, i.kind, i.line) for i in upward(found)) == [
        ("flexhrc.cli.main", FUNCTION, 9),
        ("flexhrc.knowledge.base", TYPE_CHECKING, 6),
        ("flexhrc.taskmanager.manager", FUNCTION, 10),
    ]
    assert ("flexhrc.cli.main", "flexhrc.logic", TOP) in {
        (i.source, i.target, i.kind) for i in found
    }
    assert upward(found)[0].where(pkg) == "src/flexhrc/logic/terms.py:6"
    # logic.terms -> knowledge.base -> logic.terms, closed under TYPE_CHECKING; the packages
    # logic -> cli -> logic too
    assert module_cycles(found) == [["flexhrc.knowledge.base", "flexhrc.logic.terms"]]
    assert package_cycles(found) == [["cli", "knowledge", "logic"]]


def test_checker_refuses_sideways_imports_without_leave(tmp_path):
    pkg = _package(
        tmp_path,
        {
            "errors.py": "",
            "files.py": "from flexhrc.errors import FlexhrcError\n",
            "jsonl.py": "from flexhrc.files import read_text\n",
            "web/__init__.py": "",
            "web/app.py": "from flexhrc.ros2.transport import RosTransport\n",
            "ros2/__init__.py": "",
            "ros2/transport.py": "",
        },
    )
    assert FLOORS["web"] == FLOORS["ros2"]
    assert [(i.source, i.target) for i in upward(imports(pkg))] == [
        ("flexhrc.web.app", "flexhrc.ros2.transport")
    ]


def test_checker_names_a_package_missing_from_the_table(tmp_path):
    pkg = _package(tmp_path, {"gadgets/__init__.py": "", "errors.py": ""})
    assert unplaced(pkg) == ["gadgets"]
    assert any(
        "'gadgets' is not in the layer table: add it to FLOORS" in line for line in problems(pkg)
    )
    assert "floor ?   (not in FLOORS)\n          gadgets/" in _layers.diagram(pkg)


@pytest.mark.parametrize(
    ("edges", "expected"),
    [
        ({"a": ["b"], "b": ["c"], "c": []}, []),
        ({"a": ["b"], "b": ["a"]}, [["a", "b"]]),
        ({"a": ["b"], "b": ["c"], "c": ["a"], "d": ["d", "a"]}, [["a", "b", "c"]]),
        ({"a": ["b"], "b": ["a"], "c": ["d"], "d": ["c", "a"]}, [["a", "b"], ["c", "d"]]),
    ],
)
def test_strongly_connected_components(edges, expected):
    assert _layers.cycles(edges) == expected
