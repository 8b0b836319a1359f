import pytest

from flexhrc.behavior import (
    AND,
    BEHAVIOR,
    OR,
    THEN,
    load_task_document,
    parse_prefix,
    parse_task,
    to_ascii,
    to_dot,
)
from flexhrc.errors import FormatError

FIG1 = "(THEN a (AND (THEN b c) (OR d e (THEN f g))))"


def test_fig1_prefix_parses_into_named_goal_nodes():
    task = parse_prefix(FIG1)
    root = task.root
    assert (root.kind, root.name) == (THEN, "THEN_1")
    assert [c.name for c in root.children] == ["a", "AND_1"]
    and1 = root.children[1]
    assert and1.kind == AND
    assert [c.kind for c in and1.children] == [THEN, OR]
    assert [c.name for c in and1.children[1].children] == ["d", "e", "THEN_3"]
    assert task.behaviors == ["a", "b", "c", "d", "e", "f", "g"]
    assert task.size == 12
    assert task.to_prefix() == FIG1
    assert and1.children[1].name == "OR_1" and and1.children[1].children[2].name == "THEN_3"


def test_paper_comma_form_and_lower_case_operators_are_accepted():
    assert parse_prefix("(THEN a, (and (THEN b c) (or d e (THEN f g))))").to_prefix() == FIG1


@pytest.mark.parametrize(
    ("text", "line", "fragment"),
    [
        ("(THEN a (AND b c)", 1, "column 1: '(' is never closed"),
        ("(THEN a b))", 1, "column 11: unexpected ')'"),
        ("(XOR a b)", 1, "column 2: expected THEN, AND or OR"),
        ("(THEN a a)", 1, "appears twice (first at line 1, column 7)"),
        ("(THEN a (OR))", 1, "column 9: OR goal needs at least one child"),
        (
            "(THEN a\n  (AND b\n    (FOO c)))",
            3,
            "column 6: expected THEN, AND or OR after '(', got 'FOO'",
        ),
        ("(THEN a b) c", 1, "column 12: unexpected 'c'"),
        ("", 1, "empty task"),
        ("(THEN a THEN)", 1, "'THEN' is a goal type"),
        ("(THEN a b$)", 1, "invalid behaviour name 'b$'"),
    ],
)
def test_prefix_errors_name_line_and_column(text, line, fragment):
    with pytest.raises(FormatError) as info:
        parse_prefix(text, "task.txt")
    err = info.value
    assert err.line == line
    assert err.source == "task.txt"
    assert fragment in str(err)
    assert str(err).startswith(f"task.txt:{line}:")


def test_yaml_form_equals_prefix_form_and_keeps_world():
    text = """
name: demo
task:
  THEN:
    - a
    - AND:
        - THEN: [b, c]
        - OR: [d, e, {THEN: [f, g]}]
world:
  objects:
    a: {position: [0.5, 0.0, 0.75], target: [1.0, 0.0, 0.75]}
    b: {position: [0.5, 0.2, 0.75]}
"""
    doc = load_task_document(text, "demo.yaml")
    assert doc.task.to_prefix() == FIG1
    assert doc.name == "demo"
    assert doc.world is not None and sorted(doc.world.objects) == ["a", "b"]
    assert doc.world.objects["b"].target is None
    assert parse_task(text).to_prefix() == FIG1
    assert parse_task("# comment\n" + FIG1).to_prefix() == FIG1


@pytest.mark.parametrize(
    ("text", "line", "fragment"),
    [
        ("task:\n  THEN:\n    - a\n    - XOR: [b, c]\n", 4, "unknown goal type 'XOR'"),
        ("task:\n  THEN: a\n", 2, "THEN expects a list"),
        ("name: x\n", 1, "missing 'task'"),
        ("task: [a\n", 2, "invalid YAML"),
        ("task: {AND: [a, b]}\nworld:\n  objects:\n    a: {position: [1, 2]}\n", 4, "3 numbers"),
        (
            "task: {AND: [a, b]}\nworld:\n  objects:\n    a: {posit: [1, 2, 3]}\n",
            4,
            "unknown key 'posit'",
        ),
        ("task: {AND: [a, b]}\nwrld: {}\n", 2, "unknown key 'wrld'"),
        ("task:\n  AND:\n    - a\n    - {THEN: [b, a]}\n", 4, "appears twice"),
        (
            "task: {AND: [a]}\nworld:\n  objects: {a: {position: [1, 2, 3]}}\n"
            "  moves:\n    - {object: a, to: [1, 1, 1]}\n",
            5,
            "exactly one of 'at' or 'during_grasp'",
        ),
    ],
)
def test_yaml_errors_name_the_line(text, line, fragment):
    with pytest.raises(FormatError) as info:
        load_task_document(text, "bad.yaml")
    assert info.value.line == line, str(info.value)
    assert fragment in str(info.value)


def test_ascii_and_dot_rendering():
    task = parse_prefix(FIG1)
    art = to_ascii(task)
    assert art.splitlines()[0] == "THEN (THEN_1)"
    assert "├── a" in art
    assert "    ├── THEN (THEN_2)\n    │   ├── b" in art
    assert art.splitlines()[-1] == "            └── g"
    dot = to_dot(task, {"a": {"state": "done", "level": 0.0, "potential": 1.0}})
    assert dot.startswith('digraph "task" {')
    assert '"OR_1" -> "THEN_3";' in dot
    assert dot.count("->") == task.size - 1
    assert '"a" [shape=ellipse, label="a", style=filled, fillcolor="#3c78d8"];' in dot
    assert all(n.kind in (THEN, AND, OR, BEHAVIOR) for n in task.walk())
