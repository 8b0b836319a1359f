"""One loop drives the Task Manager: :class:`flexhrc.cell.supervisor.Cell` (issue 19, item 1).

The Task Manager is sans-IO: it changes only when one of its entry points is called with an
input — ``start``, ``on_ack``, ``on_human_action``, ``on_percept``, ``replan``,
``set_available``, ``operator_takes`` — and answers with directives. Whoever calls them is a
loop around it. This test reads the source (as ``tests/test_architecture.py`` does) and checks
that exactly one module does: ``flexhrc/cell/supervisor.py``. Every front end (``run``,
``demo``, ``cell``, the panel, ROS 2, perception in the loop) is a configuration of that loop.
"""

from __future__ import annotations

import ast
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src" / "flexhrc"

#: The Task Manager's decision and acknowledgement entry points.
ENTRY_POINTS = frozenset(
    {
        "start",
        "on_ack",
        "on_human_action",
        "on_percept",
        "replan",
        "set_available",
        "operator_takes",
    }
)
THE_LOOP = "cell/supervisor.py"
MANAGER = "taskmanager/manager.py"


def _manager_calls(tree: ast.AST) -> list[tuple[int, str]]:
    """Calls of an entry point on something that is a Task Manager by its name: ``tm``,
    ``self.tm``, ``manager``, ``self.manager``, ``*.tm`` (``start`` is a common word: a thread
    starts too, so only these receivers count)."""
    found = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call) or not isinstance(node.func, ast.Attribute):
            continue
        if node.func.attr not in ENTRY_POINTS:
            continue
        receiver = node.func.value
        name = receiver.attr if isinstance(receiver, ast.Attribute) else getattr(receiver, "id", "")
        if name in ("tm", "manager", "task_manager"):
            found.append((node.lineno, node.func.attr))
    return found


def _constructions(tree: ast.AST) -> list[int]:
    return [
        node.lineno
        for node in ast.walk(tree)
        if isinstance(node, ast.Call)
        and isinstance(node.func, ast.Name | ast.Attribute)
        and (node.func.id if isinstance(node.func, ast.Name) else node.func.attr) == "TaskManager"
    ]


def test_only_the_cell_drives_the_task_manager() -> None:
    callers: dict[str, list[tuple[int, str]]] = {}
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC).as_posix()
        if rel in (THE_LOOP, MANAGER):
            continue
        calls = _manager_calls(ast.parse(path.read_text(), str(path)))
        if calls:
            callers[rel] = calls
    assert not callers, (
        "only flexhrc/cell/supervisor.py (the one loop) may feed the Task Manager; "
        f"these modules call its entry points: {callers}"
    )
    loop = ast.parse((SRC / THE_LOOP).read_text())
    assert {name for _, name in _manager_calls(loop)} >= {"start", "on_ack", "on_human_action"}


def test_only_the_cell_makes_a_task_manager() -> None:
    makers = {
        path.relative_to(SRC).as_posix(): lines
        for path in sorted(SRC.rglob("*.py"))
        if path.relative_to(SRC).as_posix() != MANAGER
        and (lines := _constructions(ast.parse(path.read_text(), str(path))))
    }
    assert set(makers) == {THE_LOOP}, makers


def test_the_scan_sees_a_second_loop() -> None:
    """The check itself: a module that feeds a manager is found."""
    rogue = ast.parse("def loop(tm, ack):\n    tm.start(0.0)\n    self.tm.on_ack(1.0, ack)\n")
    assert _manager_calls(rogue) == [(2, "start"), (3, "on_ack")]
    assert _manager_calls(ast.parse("import threading\nthreading.Thread().start()\n")) == []
    assert _constructions(ast.parse("x = TaskManager(g, d, kb)\n")) == [1]
