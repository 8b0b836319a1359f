"""Every malformed file gives exactly one clear error line with file and line, exit code 2."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from flexhrc.cli import main

from ..conftest import subprocess_env

GOOD_LOWER = """\
Lower 3 r
a 0
b 0
r 0
h 2 r 1 -
a
b
"""

# name -> (files {name: text}, line of the fault in main.txt/main.yaml, words in the message)
CASES: dict[str, tuple[dict[str, str], int, str]] = {
    "empty file": ({"main.txt": "\n"}, 1, "empty file"),
    "bad header": ({"main.txt": "G 3\na 0\n"}, 1, "header must be"),
    "node count not integer": ({"main.txt": "G x r\n"}, 1, "not an integer"),
    "node weight not numeric": (
        {"main.txt": "G 2 r\na zero\nr 0\nh 1 r 1 -\na\n"},
        2,
        "not a number",
    ),
    "negative weight": ({"main.txt": "G 2 r\na 0\nr 0\nh 1 r -1 -\na\n"}, 4, ">= 0"),
    "duplicate node": ({"main.txt": "G 3 r\na 0\na 0\nr 0\nh 1 r 1 -\na\n"}, 3, "duplicate node"),
    "unknown child": (
        {"main.txt": "G 2 r\na 0\nr 0\nh 1 r 1 -\nzz\n"},
        4,
        "unknown child node 'zz'",
    ),
    "unknown parent": ({"main.txt": "G 2 r\na 0\nr 0\nh 1 q 1 -\na\n"}, 4, "unknown parent"),
    "wrong child count": (
        {"main.txt": "G 3 r\na 0\nb 0\nr 0\nh1 3 r 1 -\na\nb\nh2 1 r 1 -\na\n"},
        8,
        "declares 3 children but 2 follow",
    ),
    "child count at end of file": (
        {"main.txt": "G 2 r\na 0\nr 0\nh 2 r 1 -\na\n"},
        4,
        "declares 2",
    ),
    "missing root": ({"main.txt": "G 2 top\na 0\nr 0\nh 1 r 1 -\na\n"}, 1, "root node 'top'"),
    "root has a parent": (
        {"main.txt": "G 3 r\na 0\nr 0\nx 0\nh 1 r 1 -\na\nk 1 x 1 -\nr\n"},
        7,
        "is a child of hyper-arc",
    ),
    "cycle": (
        {
            "main.txt": "G 4 r\na 0\nb 0\nc 0\nr 0\nh1 1 b 1 -\na\nh2 1 c 1 -\nb\nh3 1 a 1 -\nc\n"
            "h4 1 r 1 -\nb\n"
        },
        6,
        "cycle: a -> h1 -> b -> h2 -> c -> h3 -> a",
    ),
    "missing lower-graph file": (
        {"main.txt": "G 3 r\na 0\nb 0\nr 0\nh 2 r 1 nowhere\na\nb\n"},
        5,
        "lower graph file 'nowhere' not found",
    ),
    "lower-graph mapping mismatch": (
        {
            "main.txt": "G 4 r\na 0\nb 0\nc 0\nr 0\nh 3 r 1 lower\na\nb\nc\n",
            "lower.txt": GOOD_LOWER,
        },
        6,
        "mapping M1",
    ),
    "announced more nodes than listed": (
        {"main.txt": "G 3 r\na 0\nr 0\nh 1 r 1 -\na\n"},
        4,
        "node line must be",
    ),
    "lower graphs refer to each other": (
        {"main.txt": "G 3 r\na 0\nb 0\nr 0\nh 2 r 1 main\na\nb\n"},
        5,
        "cycle",
    ),
    "yaml syntax": ({"main.yaml": "graphs:\n  g: [\n"}, 3, "YAML syntax error"),
    "yaml unknown key": (
        {"main.yaml": "graphs:\n  g:\n    root: r\n    nodes: [r]\n    colour: red\n"},
        5,
        "unknown key 'colour'",
    ),
    "yaml multiple roots": (
        {
            "main.yaml": textwrap.dedent("""\
            graphs:
              g:
                nodes: [a, b, r, s]
                hyperarcs:
                  - {name: h, children: [a], parent: r}
                  - {name: k, children: [b], parent: s}
            """)
        },
        2,
        "multiple roots",
    ),
    "yaml leaf mapping mismatch": (
        {
            "main.yaml": textwrap.dedent("""\
            top: g
            graphs:
              g:
                root: r
                nodes: [a, b, r]
                hyperarcs:
                  - name: h
                    children: [a, b]
                    parent: r
                    lower: low
                    leaves: {a: [p], b: [nope]}
              low:
                root: q
                nodes: [p, s, q]
                hyperarcs:
                  - {name: l, children: [p, s], parent: q}
            """)
        },
        7,
        "not a leaf of lower graph",
    ),
    "yaml bad weight": (
        {"main.yaml": "graphs:\n  g:\n    root: r\n    nodes:\n      - {name: r, weight: heavy}\n"},
        5,
        "not a number",
    ),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_malformed_file_gives_one_error_with_file_and_line(case, tmp_path, capsys):
    files, line, words = CASES[case]
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    main_file = tmp_path / next(n for n in files if n.startswith("main"))
    code = main(["graph", "validate", str(main_file)])
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1, err
    assert err.startswith(f"error: {main_file}:{line}: "), err
    assert words in err


def test_no_traceback_from_the_real_command(tmp_path):
    bad = tmp_path / "bad.txt"
    bad.write_text("G 2 r\na 0\nr 0\nh 1 r 1 -\nzz\n")
    env = subprocess_env()
    proc = subprocess.run(
        [sys.executable, "-m", "flexhrc", "graph", "stats", str(bad)],
        capture_output=True,
        text=True,
        env=env,
    )
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    assert f"{bad}:4" in proc.stderr


def test_missing_file_is_a_clear_error(tmp_path, capsys):
    assert main(["graph", "validate", str(tmp_path / "nope.txt")]) == 2
    assert "no such file" in capsys.readouterr().err
