"""The compiled common case of the ANDOR text reader (``_andor_fast.c``) changes no answer.

For every input it either declines (None: the Python reader parses the file and names any
fault) or returns exactly the flat form the pure-Python fast path builds: the same names,
weights, ids, orders, line numbers, references and warnings. It is never allowed to accept a
file the Python fast path refuses. Checked on every graph file we have and on thousands of
seeded mutations of them (the faults and oddities of ``../shared/reviews`` among them).
"""

from __future__ import annotations

import random
import subprocess
import sys
from pathlib import Path

import pytest

from flexhrc.representation.formats import andor_text

from ..conftest import subprocess_env

REPO = Path(__file__).resolve().parents[2]

fast = pytest.importorskip(
    "flexhrc.representation.formats._andor_fast",
    reason="the compiled reader is not built (no C compiler at install): nothing to compare",
)


def _python_flat(path: Path, data: bytes) -> tuple[object, ...] | None:
    rows, nums = andor_text._rows(path, data)
    return andor_text._parse_flat(path, rows, nums)


def _same(path: Path, data: bytes) -> bool:
    """Whether the compiled reader declines ``data`` or agrees with the Python fast path;
    True when it accepted the file."""
    compiled = fast.parse(data)
    try:
        python = _python_flat(path, data)
    except Exception:  # the Python reader refuses the bytes (binary, not UTF-8)
        python = None
    if compiled is None:
        return False
    assert python is not None, f"the compiled reader accepts what Python refuses: {data!r}"
    g, refs = andor_text._from_compiled(path, compiled)
    ref, ref_refs = python
    ix, rx = g._ix, ref._ix
    for slot in ("names", "n_nodes", "weights", "children", "parent", "incoming", "lower",
                 "root", "topo", "leaves"):  # fmt: skip
        assert getattr(ix, slot) == getattr(rx, slot), (slot, data)
    assert list(ix.lines) == list(rx.lines), data
    assert (g.name, g.root, g.root_line, g.source) == (
        ref.name,
        ref.root,
        ref.root_line,
        ref.source,
    )
    assert refs == ref_refs, data
    assert [str(w) for w in g._validated[1]] == [str(w) for w in ref._validated[1]], data
    # the weights are floats, as float() makes them (not ints that compare equal)
    assert all(type(w) is float for w in ix.weights)
    return True


def _corpus(anchors: Path | None) -> list[Path]:
    out = sorted((REPO / "examples" / "graphs").rglob("*.txt"))
    if anchors is not None and anchors.is_dir():
        out += sorted(anchors.rglob("*.txt"))
    return out


@pytest.fixture(scope="module")
def corpus() -> list[Path]:
    anchors = REPO.parent / "shared" / "anchors" / "andor-graphs"
    return _corpus(anchors if anchors.is_dir() else None)


def test_every_graph_file_is_read_the_same(corpus: list[Path]) -> None:
    accepted = sum(_same(f, f.read_bytes()) for f in corpus)
    # every file without comments: the examples, and the authors' files but their
    # *Commented.txt ones (which the Python reader reads)
    assert accepted >= len([f for f in corpus if b"#" not in f.read_bytes()])


_ODD = [b"\r\n", b"\r", b"\t", b"  ", b" \n", b"\n\n", b"\x00", b"\x0c", b"\x1c", b"#",
        "é".encode(), b"\xff", b"\xef\xbb\xbf", b"/", b"0", b"-", b"+1", b"1_0", b"9" * 16]  # fmt: skip


def _mutate(rng: random.Random, data: bytes) -> bytes:
    lines = data.split(b"\n")
    op = rng.randrange(15)
    i = rng.randrange(len(lines))
    if op == 0:  # drop a line
        del lines[i]
    elif op == 1:  # repeat a line (a repeated name, a child twice, one child too many)
        lines.insert(i, lines[i])
    elif op == 2:  # swap two lines (order, counts, a parent before its children)
        k = rng.randrange(len(lines))
        lines[i], lines[k] = lines[k], lines[i]
    elif op == 3:  # an odd byte sequence somewhere in a line
        pos = rng.randrange(len(lines[i]) + 1)
        lines[i] = lines[i][:pos] + rng.choice(_ODD) + lines[i][pos:]
    elif op == 4:  # a field taken from another line of its kind (a repeated name, ...)
        words = lines[i].split(b" ")
        j = rng.randrange(len(words))
        alike = [w for w in (x.split(b" ") for x in lines) if len(w) == len(words)]
        words[j] = rng.choice(alike)[j]
        lines[i] = b" ".join(words)
    elif op == 5:  # a number changed
        words = lines[i].split(b" ")
        j = rng.randrange(len(words))
        words[j] = str(rng.choice([0, 1, 2, 3, 7, 10, 99, 2**53 + 1, -1])).encode()
        lines[i] = b" ".join(words)
    elif op == 6:  # two lines joined
        if i + 1 < len(lines):
            lines[i : i + 2] = [lines[i] + b" " + lines[i + 1]]
    elif op == 7:  # a line split at a space
        if b" " in lines[i]:
            a, b = lines[i].split(b" ", 1)
            lines[i : i + 1] = [a, b]
    elif op == 8:  # cut short
        lines = lines[: max(1, i)]
    elif op == 9:  # a lower-graph reference or its absence
        words = lines[i].split(b" ")
        if len(words) == 5:
            words[4] = rng.choice([b"-", b"Sub", b"a/b", b"--"])
            lines[i] = b" ".join(words)
    elif op == 10:  # CRLF line ends throughout, or a final newline more or less
        return data.replace(b"\n", b"\r\n") if rng.random() < 0.5 else data.rstrip(b"\n")
    elif op == 11:  # a child made the root
        if len(lines[i].split()) == 1 and i > 0:
            lines[i] = data.split()[2]
    elif op == 12:  # a field more on a line
        lines[i] = lines[i] + b" " + rng.choice(lines[i].split() or [b"x"])
    elif op == 13:  # a slash in a name
        words = lines[i].split(b" ")
        words[0] = words[0][:1] + b"/" + words[0][1:]
        lines[i] = b" ".join(words)
    else:  # the parent of a hyper-arc made one of its children or the root
        words = lines[i].split(b" ")
        if len(words) == 5 and i + 1 < len(lines):
            words[2] = rng.choice([lines[i + 1].strip(), data.split()[2]])
            lines[i] = b" ".join(words)
    return b"\n".join(lines)


def test_mutated_files_are_declined_or_read_the_same(corpus: list[Path]) -> None:
    rng = random.Random(9)
    small = [f for f in corpus if f.stat().st_size < 4000]
    accepted = declined = 0
    for _ in range(4000):
        f = rng.choice(small)
        data = f.read_bytes()
        for _ in range(rng.randrange(1, 3)):
            data = _mutate(rng, data)
        if _same(f, data):
            accepted += 1
        else:
            declined += 1
    # both sides of the decision are exercised
    assert accepted > 300 and declined > 300, (accepted, declined)


def test_a_file_is_read_as_its_bytes_are(corpus: list[Path], tmp_path: Path) -> None:
    for f in corpus:
        data = f.read_bytes()
        parsed = fast.parse(data)
        # what it declines comes back as the bytes it read (the Python reader's to parse)
        assert fast.parse_file(f) == (data if parsed is None else parsed), f
        assert fast.parse_file(str(f)) == fast.parse_file(f)
    big = tmp_path / "big.txt"  # more than one read's worth (64 KiB)
    n = 6000
    lines = [f"big {n + 1} r", *(f"n{i} 0" for i in range(n)), "r 0"]
    lines += [f"h{i} 1 r 1 -\nn{i}" for i in range(n)]
    big.write_text("\n".join(lines) + "\n")
    assert big.stat().st_size > 1 << 17
    assert fast.parse_file(big) == fast.parse(big.read_bytes()) is not None
    # what it cannot read is the Python reader's to report
    for bad in (tmp_path / "missing.txt", tmp_path, "a\x00b", b"\xff\xfe"):
        assert fast.parse_file(bad) is None
    with pytest.raises(TypeError):
        fast.parse_file(3)  # type: ignore[arg-type]


def test_junk_is_declined() -> None:
    for data in (b"", b"\n\n", b"g 1 r", b"g 0 r\nr 0\nh 1 r 1 -\nr\n", b"\x00" * 10,
                 b"g 1 r\nr 0\n", b"g 99999999999 r\nr 0\nh 1 r 0 -\nx\n"):  # fmt: skip
        assert fast.parse(data) is None, data
    with pytest.raises(TypeError):
        fast.parse("g 1 r")  # type: ignore[arg-type]


def test_pure_python_reading_gives_the_same_hierarchy(anchors_dir: Path) -> None:
    """FLEXHRC_PURE_PYTHON=1 turns the compiled reader off (in a fresh process: it is chosen
    at import); the kitchen, all 32 files, loads to the same definitions."""
    kitchen = anchors_dir / "TRO-IKEAKitchenAssembly" / "KitchenAssembly.txt"
    code = (
        "import sys; from flexhrc.representation import load; "
        "from flexhrc.representation.formats import andor_text as a; "
        "h = load(sys.argv[1]); "
        "print(a._parse_compiled is not None, "
        "repr(sorted((k, sorted(g.nodes), sorted((x.name, x.children, x.parent, x.weight, "
        "x.lower, x.line) for x in g.hyperarcs.values())) for k, g in h.graphs.items())))"
    )
    out = {}
    for pure in ("0", "1"):
        env = subprocess_env()
        env["FLEXHRC_PURE_PYTHON"] = pure
        proc = subprocess.run(
            [sys.executable, "-c", code, str(kitchen)],
            env=env,
            capture_output=True,
            text=True,
            timeout=60,
            check=True,
        )
        compiled, _, dump = proc.stdout.partition(" ")
        assert compiled == ("True" if pure == "0" else "False")
        out[pure] = dump
    assert out["0"] == out["1"]
