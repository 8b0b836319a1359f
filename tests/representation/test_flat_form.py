"""The flat, id-based form the ANDOR text reader builds (issue 9, item 6) changes no answer.

The reader's fast path parses a well-formed file straight into :class:`Indexed` arrays — no
:class:`Node` or :class:`Hyperarc` until ``nodes``/``hyperarcs`` are first read — and finds lower
graphs in cached folder listings. Everything must be as with the element-wise parse and the
``stat``-based lookup: the same definitions, line numbers, warnings, orders, errors and answers.
"""

from __future__ import annotations

import gc
from pathlib import Path

import pytest

from flexhrc.errors import FormatError
from flexhrc.representation import OnlineGraph, load
from flexhrc.representation.formats import andor_text
from flexhrc.representation.formats.andor_text import load_andor_text
from flexhrc.representation.graph import AndOrGraph
from flexhrc.representation.hierarchy import HierarchicalGraph

REPO = Path(__file__).resolve().parents[2]


def _files(anchors: Path | None) -> list[Path]:
    out = sorted((REPO / "examples" / "graphs").glob("*.txt"))
    if anchors is not None and anchors.is_dir():
        out += sorted(anchors.rglob("*.txt"))
    return out


def _slow(monkeypatch: pytest.MonkeyPatch, f: Path) -> HierarchicalGraph:
    """The hierarchy as the element-wise parse and the stat-based lookup make it."""
    with monkeypatch.context() as m:
        m.setattr(andor_text, "_parse_compiled", None)
        m.setattr(andor_text, "_parse_flat", lambda *a: None)
        m.setattr(andor_text, "_find_listed", lambda *a: None)
        return load_andor_text(f)


def _lines(g: AndOrGraph) -> tuple[list[int | None], list[int | None]]:
    return [n.line for n in g.nodes.values()], [h.line for h in g.hyperarcs.values()]


@pytest.mark.parametrize("compiled", [True, False], ids=["compiled", "python"])
def test_flat_and_element_wise_parses_are_the_same(
    anchors_dir: Path, monkeypatch: pytest.MonkeyPatch, compiled: bool
) -> None:
    """The flat form, from the compiled reader (when it is built) or the Python fast path."""
    if not compiled:
        monkeypatch.setattr(andor_text, "_parse_compiled", None)
    flat_files = 0
    for f in _files(anchors_dir):
        try:
            fast = load_andor_text(f)
        except FormatError as exc:
            with pytest.raises(FormatError) as slow_err:
                _slow(monkeypatch, f)
            assert str(slow_err.value) == str(exc)
            continue
        slow = _slow(monkeypatch, f)
        assert list(fast.graphs) == list(slow.graphs), f
        for key, g in fast.graphs.items():
            ref = slow.graphs[key]
            flat_files += g._ix is not None
            # read before anything unpacks the flat form
            assert len(g) == len(ref)
            assert g.leaves() == ref.leaves(), f
            assert g.topological_order() == ref.topological_order(), f
            assert [str(w) for w in g.validate()] == [str(w) for w in ref.validate()], f
            assert g == ref, f  # (unpacks: Node and Hyperarc objects compared)
            assert _lines(g) == _lines(ref), f
            assert (g.root, g.root_line, g.source) == (ref.root, ref.root_line, ref.source)
        a, b = OnlineGraph(load(f)), OnlineGraph(slow)
        assert a.optimal_cost() == b.optimal_cost()
        assert a.query().to_dict() == b.query().to_dict()
        assert a.state() == b.state()
    assert flat_files > 30


def _write(tmp_path: Path, body: str) -> Path:
    f = tmp_path / "g.txt"
    f.write_text(body, encoding="utf-8")
    return f


def test_hyper_arcs_listed_parents_first_take_kahns_order(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # h_top consumes m before h_m (which makes m) is listed: not the authors' order
    f = _write(tmp_path, "g 4 r\na 1\nb 2\nm 3\nr 0\nh_top 2 r 1 -\nm\nb\nh_m 1 m 5 -\na\n")
    fast = load(f)
    g = fast.top_graph
    assert g._ix is not None
    assert g.topological_order() == _slow(monkeypatch, f).top_graph.topological_order()
    online = OnlineGraph(fast)
    assert online.optimal_cost() == 1 + 2 + 3 + 1 + 5
    assert sorted(online.query().feasible) == ["a", "b"]


@pytest.mark.parametrize(
    "body",
    [
        # a cycle through the authors' order check and through Kahn's
        "g 4 r\na 0\nb 0\nc 0\nr 0\nh1 1 b 1 -\nc\nh2 1 c 1 -\nb\nh3 2 r 1 -\na\nb\n",
        "g 4 r\na 0\nb 0\nc 0\nr 0\nh3 2 r 1 -\na\nb\nh1 1 b 1 -\nc\nh2 1 c 1 -\nb\n",
    ],
)
def test_a_cycle_is_named_as_before(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, body: str
) -> None:
    f = _write(tmp_path, body)
    with pytest.raises(FormatError, match="cycle") as fast:
        load(f)
    with pytest.raises(FormatError) as slow:
        _slow(monkeypatch, f).validate()
    assert str(fast.value) == str(slow.value)


def test_an_unpacked_graph_that_is_changed_is_what_the_engine_sees(tmp_path: Path) -> None:
    f = _write(tmp_path, "g 3 r\na 0\nb 0\nr 0\nh 2 r 1 -\na\nb\n")
    h = load(f)
    g = h.top_graph
    assert g._ix is not None
    g.add_node("c", 4)  # unpacks: the dicts are the graph from now on
    g.add_hyperarc("h2", ["c"], "r", 1)
    assert g._ix is None
    h.validate()
    online = OnlineGraph(h)
    assert online.optimal_cost() == 1  # h (a, b: 0) beats h2 (c: 4, + 1)
    assert sorted(online.query().feasible) == ["a", "b", "c"]


def test_lower_graphs_through_links_are_judged_by_stat(tmp_path: Path) -> None:
    top = tmp_path / "top"
    (top / "real").mkdir(parents=True)
    (top / "real" / "low.txt").write_text("low 2 r\np 0\nr 0\nl 1 r 2 -\np\n", encoding="utf-8")
    (top / "linked").symlink_to(top / "real")  # a link inside the top folder: allowed
    (top / "g.txt").write_text("g 2 t\nx 0\nt 0\nH 1 t 1 linked/low\nx\n", encoding="utf-8")
    h = load(top / "g.txt")
    assert set(h.graphs) == {"g", "linked/low"}
    assert OnlineGraph(h).optimal_cost() == 2
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    (outside / "low.txt").write_text("low 2 r\np 0\nr 0\nl 1 r 2 -\np\n", encoding="utf-8")
    (top / "away").symlink_to(outside)  # a link that leaves the top folder: refused
    (top / "g2.txt").write_text("g 2 t\nx 0\nt 0\nH 1 t 1 away/low\nx\n", encoding="utf-8")
    with pytest.raises(FormatError, match="outside the top graph"):
        load(top / "g2.txt")


def test_a_folder_named_like_the_file_falls_back_to_the_bare_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "low.txt").mkdir()  # "low" + ".txt" is a folder: the file "low" is meant
    (tmp_path / "low").write_text("low 2 r\np 0\nr 0\nl 1 r 2 -\np\n", encoding="utf-8")
    f = tmp_path / "g.txt"
    f.write_text("g 2 t\nx 0\nt 0\nH 1 t 1 low\nx\n", encoding="utf-8")
    h = load_andor_text(f)
    assert set(h.graphs) == {"g", "low"}
    assert h == _slow(monkeypatch, f)


@pytest.mark.parametrize("enabled", [True, False])
def test_the_collector_is_left_as_it_was(tmp_path: Path, enabled: bool) -> None:
    good = _write(tmp_path, "g 3 r\na 0\nb 0\nr 0\nh 2 r 1 -\na\nb\n")
    bad = tmp_path / "bad.txt"
    bad.write_text("g 3 r\na 0\n", encoding="utf-8")
    was = gc.isenabled()
    try:
        gc.enable() if enabled else gc.disable()
        OnlineGraph(load(good))
        assert gc.isenabled() is enabled
        with pytest.raises(FormatError):
            load(bad)
        assert gc.isenabled() is enabled
    finally:
        gc.enable() if was else gc.disable()
