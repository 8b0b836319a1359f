"""First-order logic for cooperation states (paper 000, eqs. 1-2).

A cooperation state is described by a conjunction of literals, e.g.
``connected(?leg, ?plate) & not held(?leg)``. Terms starting with ``?`` are variables, every
other term is a constant. Variables are grounded at run time by matching the literals against
the ground facts of the knowledge base (closed world: a fact that is not stored is false).

The common case — a node whose state is just its own name — never touches this module, so it
costs nothing.
"""

from flexhrc.logic.terms import (
    Conjunction,
    Literal,
    Substitution,
    apply_substitution,
    ground,
    index_facts,
    is_variable,
    match_literal,
    parse_conjunction,
    parse_literal,
    satisfy,
    variables_of,
)

__all__ = [
    "Conjunction",
    "Literal",
    "Substitution",
    "apply_substitution",
    "ground",
    "index_facts",
    "is_variable",
    "match_literal",
    "parse_conjunction",
    "parse_literal",
    "satisfy",
    "variables_of",
]
