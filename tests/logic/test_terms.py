import pytest

from flexhrc.errors import FormatError
from flexhrc.logic import (
    Literal,
    ground,
    is_variable,
    match_literal,
    parse_conjunction,
    parse_literal,
    satisfy,
    variables_of,
)


def test_parse_literal_forms():
    assert parse_literal("connected(?leg, plate)") == Literal("connected", ("?leg", "plate"))
    assert parse_literal("not held(?x)") == Literal("held", ("?x",), True)
    assert parse_literal("!held(a)").negated
    assert parse_literal("Leg1_T") == Literal("Leg1_T")
    assert str(parse_literal("not p(a, ?b)")) == "not p(a, ?b)"


@pytest.mark.parametrize("bad", ["p(a", "p(a,)", "p(a b)", "", "p(a)(b)"])
def test_parse_literal_rejects_malformed(bad):
    with pytest.raises(FormatError):
        parse_literal(bad)


def test_parse_conjunction_separators():
    c = parse_conjunction("a(?x, b) & not c(?x) and d")
    assert [str(lit) for lit in c] == ["a(?x, b)", "not c(?x)", "d"]
    assert parse_conjunction(["p(a)", "q"]) == (Literal("p", ("a",)), Literal("q"))
    with pytest.raises(FormatError, match="unbalanced"):
        parse_conjunction("p(a & q")


def test_variables_and_ground():
    c = parse_conjunction("on(?a, ?b) & clear(?a) & at(?c)")
    assert variables_of(c) == ["?a", "?b", "?c"]
    assert is_variable("?a") and not is_variable("a")
    g = ground(c, {"?a": "leg1", "?b": "plate"})
    assert str(g[0]) == "on(leg1, plate)" and g[2].args == ("?c",)


def test_match_literal_binds_and_checks_consistency():
    lit = parse_literal("on(?x, ?x)")
    assert match_literal(lit, ("on", "a", "a")) == {"?x": "a"}
    assert match_literal(lit, ("on", "a", "b")) is None
    assert match_literal(parse_literal("on(?x, b)"), ("on", "a", "b"), {"?x": "c"}) is None
    assert match_literal(parse_literal("on(?x)"), ("on", "a", "b")) is None


def test_satisfy_closed_world_with_negation():
    facts = {("leg", "l1"), ("leg", "l2"), ("leg", "l3"), ("connected", "l2")}
    sols = list(satisfy(parse_conjunction("leg(?l) & not connected(?l)"), facts))
    assert sols == [{"?l": "l1"}, {"?l": "l3"}]
    assert list(satisfy(parse_conjunction("leg(?l) & connected(?l)"), facts)) == [{"?l": "l2"}]
    assert list(satisfy(parse_conjunction("table(?t)"), facts)) == []


def test_satisfy_rejects_unsafe_negation():
    with pytest.raises(ValueError, match="unsafe"):
        list(satisfy(parse_conjunction("not connected(?l)"), set()))
