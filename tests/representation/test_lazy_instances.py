"""Lazy instantiation and parse-time validation (issue 9, item 6) change no answer.

Lower-graph instances are materialised (names, shifted index structures) only when the
instance above them becomes active or one of their elements is named; the ANDOR text reader
makes :meth:`AndOrGraph.validate`'s checks while parsing. Both must be invisible: the same
names, ids, suggestions, costs, errors and warnings as building and validating everything.
"""

from __future__ import annotations

import random
from pathlib import Path

import pytest

from flexhrc.errors import FormatError, UnknownNameError
from flexhrc.representation import OnlineGraph, load
from flexhrc.representation.formats.andor_text import load_andor_text
from flexhrc.representation.hierarchy import qualify
from flexhrc.representation.paths import exact_costs

from .helpers import two_layer

REPO = Path(__file__).resolve().parents[2]
KITCHEN = "TRO-IKEAKitchenAssembly/KitchenAssembly.txt"
HIER = "TRO-TableAssembly/4Leg/TableAssembly_hierarchical.txt"


def _eager(hierarchy: object) -> OnlineGraph:
    online = OnlineGraph(hierarchy, validate=False)  # type: ignore[arg-type]
    online._materialise_all()
    return online


def _walk(lazy: OnlineGraph, eager: OnlineGraph, seed: int) -> int:
    """Play both to the end with the same random choices; compare every answer."""
    rng = random.Random(seed)
    answer, other = lazy.query(), eager.query()
    steps = 0
    while True:
        assert answer.to_dict() == other.to_dict()
        assert lazy.state() == eager.state()
        if answer.outcome != "running":
            return steps
        name = rng.choice(sorted(answer.feasible))
        if lazy.kind(name) == "node":
            answer, other = lazy.update(met_nodes=[name]), eager.update(met_nodes=[name])
        else:
            answer = lazy.update(solved_hyperarcs=[name])
            other = eager.update(solved_hyperarcs=[name])
        steps += 1


def test_lazy_layout_names_every_element_as_the_hierarchy_does() -> None:
    h = two_layer()
    online = OnlineGraph(h)
    expected = []
    for info in h.instances():
        g = h.graphs[info.key]
        expected += [qualify(info.path, n) for n in (*g.nodes, *g.hyperarcs)]
    assert online.elements() == expected
    assert [online.element_id(n) for n in expected] == list(range(len(expected)))


def test_a_name_in_an_instance_not_built_yet_resolves_and_builds_it() -> None:
    online = OnlineGraph(two_layer())
    k = online._lower[online.element_id("H")]
    # as if not built yet (the look-ahead of one level built it with the top instance)
    online._i_mat[k] = False
    online._names[online._i_span[k][0]] = None  # type: ignore[call-overload]
    online._index_cache = None
    e = online.element_id("H/q")
    assert online._i_mat[k] and online.element_name(e) == "H/q"
    assert online.local_name("H/q") == "q" and online.graph_of("H/q") == "H"
    with pytest.raises(UnknownNameError, match="did you mean"):
        online.element_id("H/qq")
    with pytest.raises(UnknownNameError):
        online.element_id("x/q")  # x has no lower graph


@pytest.mark.parametrize("rel", [KITCHEN, HIER])
def test_lazy_and_eager_give_the_same_answers(anchors_dir: Path, rel: str) -> None:
    h = load(anchors_dir / rel)
    lazy = OnlineGraph(h, validate=False)
    if rel == KITCHEN:  # 5 levels: the top and the one below it are built, not the rest
        assert sum(lazy._i_mat) < len(lazy._i_mat)
    for seed in range(3):
        assert _walk(OnlineGraph(h, validate=False), _eager(h), seed) > 0


def test_a_first_report_without_query_0_answers_as_the_eager_build(anchors_dir: Path) -> None:
    h = load(anchors_dir / KITCHEN)
    lazy, eager = OnlineGraph(h, validate=False), _eager(h)
    leaf = sorted(_eager(h).query().feasible)[0]
    assert lazy.update(met_nodes=[leaf]).to_dict() == eager.update(met_nodes=[leaf]).to_dict()
    assert lazy.state() == eager.state()


def test_marking_a_deep_element_infeasible_before_its_instance_is_reached(
    anchors_dir: Path,
) -> None:
    h = load(anchors_dir / KITCHEN)
    lazy, eager = OnlineGraph(h, validate=False), _eager(h)
    deep = next(n for n in eager.elements() if n.count("/") >= 3 and eager.kind(n) == "hyperarc")
    assert lazy.mark_infeasible(deep).to_dict() == eager.mark_infeasible(deep).to_dict()
    assert lazy.state() == eager.state()
    assert lazy.query().feasible == exact_costs(lazy)
    eager.query()
    assert _walk(lazy, eager, 7) >= 0


def _files(anchors: Path | None) -> list[Path]:
    out = sorted((REPO / "examples" / "graphs").glob("*.txt"))
    if anchors is not None and anchors.is_dir():
        out += sorted(anchors.rglob("*.txt"))
    return out


def test_parse_time_validation_equals_validate(anchors_dir: Path) -> None:
    checked = 0
    for f in _files(anchors_dir):
        try:
            h = load_andor_text(f)
        except FormatError:
            continue  # a lower-graph file on its own may refer upwards: not ours here
        for g in h.graphs.values():
            cached = [str(w) for w in g.validate()]
            g._validated = None  # what the full check finds
            assert cached == [str(w) for w in g.validate()], g.source
            checked += 1
    assert checked > 30


def test_a_graph_changed_after_loading_is_checked_again(tmp_path: Path) -> None:
    f = tmp_path / "g.txt"
    f.write_text("g 3 r\na 0\nb 0\nr 0\nh 2 r 1 -\na\nb\n", encoding="utf-8")
    g = load(f).top_graph
    assert g.validate() == []
    g.add_hyperarc("h2", ["zz"], "r", 1)
    with pytest.raises(FormatError, match="unknown child node 'zz'"):
        g.validate()


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ("g 3 r\na 0\nb 0\nr 0\nh 2 r 1 -\na\nzz\n", "unknown child node 'zz'"),
        ("g 3 r\na 0\nb 0\nr 0\nh 2 zz 1 -\na\nb\n", "unknown parent node 'zz'"),
        ("g 3 r\na 0\nb 0\nr 0\nh 2 r 1 -\na\na\n", "child 'a' listed twice"),
        ("g 3 r\na 0\nb 0\nr 0\nh 2 a 1 -\na\nb\n", "both child and parent"),
        ("g 3 q\na 0\nb 0\nr 0\nh 2 r 1 -\na\nb\n", "root node 'q'"),
        ("g 3 a\na 0\nb 0\nr 0\nh 2 r 1 -\na\nb\n", "is a child of hyper-arc"),
        ("g 3 r\na 0\nb 0\nr 0\nh 1 r 1 -\na\nh2 1 a 1 -\nr\n", "cycle|is a child"),
    ],
)
def test_structural_faults_are_still_named(tmp_path: Path, body: str, message: str) -> None:
    f = tmp_path / "g.txt"
    f.write_text(body, encoding="utf-8")
    with pytest.raises(FormatError, match=message) as err:
        load(f)
    assert err.value.line is not None
