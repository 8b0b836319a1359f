"""Terms, literals, conjunctions and their matching against ground facts.

Terms are plain strings: ``?x`` is a variable, anything else a constant. A :class:`Literal` is a
predicate applied to terms, possibly negated. A :data:`Conjunction` is a tuple of literals — the
state formula S(n) of a node (paper 000, eq. 2) or the preconditions/effects of an action
(eq. 20). A :data:`Substitution` maps variable names to constants.

:func:`satisfy` enumerates every substitution that makes a conjunction true against a set of
ground facts under the closed-world assumption: positive literals are matched against the facts
(backtracking over them), negative literals are checked once their variables are bound.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass

from flexhrc.errors import FormatError

Substitution = dict[str, str]

_IDENT = r"[A-Za-z0-9_\-.&?]+"
_LITERAL_RE = re.compile(
    rf"^\s*(?P<neg>not\s+|!|~)?\s*(?P<pred>{_IDENT})\s*(?:\((?P<args>[^()]*)\))?\s*$"
)


def is_variable(term: str) -> bool:
    """``?x`` is a variable; every other term is a constant."""
    return term.startswith("?")


@dataclass(frozen=True, slots=True)
class Literal:
    """``predicate(arg, ...)`` or its negation. Arguments are terms (strings)."""

    predicate: str
    args: tuple[str, ...] = ()
    negated: bool = False

    def __str__(self) -> str:
        body = f"{self.predicate}({', '.join(self.args)})" if self.args else self.predicate
        return f"not {body}" if self.negated else body

    @property
    def is_ground(self) -> bool:
        return not any(is_variable(a) for a in self.args)

    def key(self) -> tuple[str, ...]:
        """The ground fact this literal denotes (predicate followed by arguments)."""
        return (self.predicate, *self.args)


Conjunction = tuple[Literal, ...]


def _quoted(text: str, limit: int = 80) -> str:
    """``text`` quoted for a message, cut to ``limit`` characters: a literal built from a YAML
    structure (aliases, nested lists) may be hundreds of kilobytes long."""
    if len(text) <= limit:
        return repr(text)
    return f"{text[:limit]!r}... ({len(text)} characters)"


def parse_literal(text: str, source: str | None = None, line: int | None = None) -> Literal:
    """Parse ``pred(a, ?x)``, ``not pred(a)``, ``!pred`` or a bare ``name``."""
    m = _LITERAL_RE.match(text)
    if not m:
        raise FormatError(f"malformed literal {_quoted(text)}", source, line)
    args_text = m.group("args")
    args: tuple[str, ...] = ()
    if args_text is not None and args_text.strip():
        args = tuple(a.strip() for a in args_text.split(","))
        if any(not a or not re.fullmatch(_IDENT, a) for a in args):
            raise FormatError(f"malformed argument list in literal {_quoted(text)}", source, line)
    return Literal(m.group("pred"), args, bool(m.group("neg")))


def parse_conjunction(
    text: str | Iterable[str], source: str | None = None, line: int | None = None
) -> Conjunction:
    """Parse ``a(?x) & not b(?x, c)`` (``&``, ``and`` or ``,`` between literals outside
    parentheses) or a list of literal strings."""
    if not isinstance(text, str):
        return tuple(parse_literal(t, source, line) for t in text)
    parts: list[str] = []
    depth, start = 0, 0
    for i, ch in enumerate(text):
        if ch == "(":
            depth += 1
        elif ch == ")":
            depth -= 1
            if depth < 0:
                raise FormatError(f"unbalanced ')' in {_quoted(text)}", source, line)
        elif ch in "&," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    if depth:
        raise FormatError(f"unbalanced '(' in {_quoted(text)}", source, line)
    parts.append(text[start:])
    out: list[Literal] = []
    for part in parts:
        for sub in re.split(r"\s+and\s+", part):
            if sub.strip():
                out.append(parse_literal(sub, source, line))
    if not out:
        raise FormatError("empty formula", source, line)
    return tuple(out)


def variables_of(formula: Iterable[Literal]) -> list[str]:
    """The variables of a formula, in order of first appearance."""
    seen: dict[str, None] = {}
    for lit in formula:
        for a in lit.args:
            if is_variable(a):
                seen.setdefault(a, None)
    return list(seen)


def apply_substitution(literal: Literal, subst: Mapping[str, str]) -> Literal:
    if not literal.args:
        return literal
    return Literal(literal.predicate, tuple(subst.get(a, a) for a in literal.args), literal.negated)


def ground(formula: Iterable[Literal], subst: Mapping[str, str]) -> Conjunction:
    return tuple(apply_substitution(lit, subst) for lit in formula)


def match_literal(
    literal: Literal, fact: tuple[str, ...], subst: Mapping[str, str] | None = None
) -> Substitution | None:
    """Extend ``subst`` so that the (positive form of the) literal equals the ground ``fact``.

    Returns the extended substitution, or None when they do not match. A variable already bound
    must agree with the fact; a variable repeated in the literal must match equal constants.
    """
    if fact[0] != literal.predicate or len(fact) - 1 != len(literal.args):
        return None
    out: Substitution = dict(subst) if subst else {}
    for term, value in zip(literal.args, fact[1:], strict=True):
        if is_variable(term):
            bound = out.get(term)
            if bound is None:
                out[term] = value
            elif bound != value:
                return None
        elif term != value:
            return None
    return out


def index_facts(facts: Iterable[tuple[str, ...]]) -> dict[str, list[tuple[str, ...]]]:
    """Ground facts by predicate, each list sorted: what :func:`satisfy` backtracks over."""
    by_pred: dict[str, list[tuple[str, ...]]] = {}
    for f in sorted(facts):
        by_pred.setdefault(f[0], []).append(f)
    return by_pred


def satisfy(
    formula: Iterable[Literal],
    facts: Iterable[tuple[str, ...]],
    subst: Mapping[str, str] | None = None,
    *,
    index: Mapping[str, Sequence[tuple[str, ...]]] | None = None,
) -> Iterator[Substitution]:
    """Every substitution (extending ``subst``) that makes the conjunction true in ``facts``.

    Closed world: a negative literal holds when its ground form is not a fact. A negative literal
    whose variables are never bound by a positive one is unsafe and raises ``ValueError``.
    Solutions come out in a deterministic order (facts sorted, literals in order). ``index`` is
    :func:`index_facts` of ``facts`` when the caller keeps it (a knowledge base queried many
    times between changes); it is made here otherwise.
    """
    lits = list(formula)
    fact_set = facts if isinstance(facts, set | frozenset) else set(facts)
    by_pred = index_facts(fact_set) if index is None else index
    positives = [lit for lit in lits if not lit.negated]
    negatives = [lit for lit in lits if lit.negated]
    bound_by_pos = set(variables_of(positives)) | set(subst or {})
    for lit in negatives:
        unsafe = [a for a in lit.args if is_variable(a) and a not in bound_by_pos]
        if unsafe:
            raise ValueError(f"unsafe negated literal {lit}: variables {unsafe} are never bound")

    def search(i: int, current: Substitution) -> Iterator[Substitution]:
        if i == len(positives):
            for lit in negatives:
                if apply_substitution(lit, current).key() in fact_set:
                    return
            yield dict(current)
            return
        lit = positives[i]
        for fact in by_pred.get(lit.predicate, ()):
            extended = match_literal(lit, fact, current)
            if extended is not None:
                yield from search(i + 1, extended)

    yield from search(0, dict(subst) if subst else {})
