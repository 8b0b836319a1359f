"""Object types from primitive fits, by rules given as data.

A rule says which primitive an object type is and its expected size, with a tolerance per
dimension (sizes sorted in decreasing order, so the rule does not depend on how the object
lies)::

    - type: leg_short
      primitive: cylinder
      size: [0.30, 0.05, 0.05]
      tolerance: [0.04, 0.015, 0.015]

An object gets the type of the matching rule with the smallest normalised size error
(``max |size - expected| / tolerance`` ≤ 1); no match gives ``unknown``. Rules load from a YAML
or JSON list, or a dict ``{"rules": [...]}``.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from flexhrc.errors import FormatError
from flexhrc.perception._io import load_yaml

PRIMITIVES = ("box", "cylinder", "sphere", "cone")


@dataclass(frozen=True)
class ClassificationRule:
    type: str
    primitive: str
    size: tuple[float, ...]
    tolerance: tuple[float, ...]

    def error(self, primitive: str, size: np.ndarray) -> float:
        """Normalised size error (``inf`` for another primitive)."""
        if primitive != self.primitive:
            return np.inf
        exp = np.sort(np.asarray(self.size))[::-1]
        return float(np.max(np.abs(np.asarray(size) - exp) / np.asarray(self.tolerance)))


#: Rules for the table-assembly scene of the synthetic generator (and the paper's table task).
DEFAULT_RULES: list[dict[str, Any]] = [
    {"type": "tabletop_large", "primitive": "box", "size": [0.80, 0.50, 0.03],
     "tolerance": [0.05, 0.05, 0.012]},
    {"type": "tabletop_small", "primitive": "box", "size": [0.60, 0.40, 0.03],
     "tolerance": [0.05, 0.05, 0.012]},
    {"type": "leg_long", "primitive": "cylinder", "size": [0.45, 0.05, 0.05],
     "tolerance": [0.05, 0.02, 0.02]},
    {"type": "leg_short", "primitive": "cylinder", "size": [0.30, 0.05, 0.05],
     "tolerance": [0.05, 0.02, 0.02]},
    {"type": "ball", "primitive": "sphere", "size": [0.08, 0.08, 0.08],
     "tolerance": [0.02, 0.02, 0.02]},
    {"type": "block", "primitive": "box", "size": [0.06, 0.06, 0.06],
     "tolerance": [0.015, 0.015, 0.015]},
    {"type": "cone", "primitive": "cone", "size": [0.10, 0.08, 0.08],
     "tolerance": [0.025, 0.025, 0.025]},
]  # fmt: skip


class RuleSet:
    """An ordered set of :class:`ClassificationRule`."""

    def __init__(self, rules: Iterable[ClassificationRule]):
        self.rules = list(rules)

    @property
    def types(self) -> list[str]:
        return [r.type for r in self.rules]

    @classmethod
    def default(cls) -> RuleSet:
        return cls.from_data(DEFAULT_RULES)

    @classmethod
    def from_data(cls, data: Any, source: str = "<rules>") -> RuleSet:
        if isinstance(data, Mapping):
            data = data.get("rules")
        if not isinstance(data, Sequence) or isinstance(data, str) or not data:
            raise FormatError("classification rules must be a non-empty list", source)
        rules = []
        for i, item in enumerate(data, start=1):
            where = f"rule {i}"
            if not isinstance(item, Mapping):
                raise FormatError(f"{where}: expected a mapping, got {type(item).__name__}", source)
            missing = [k for k in ("type", "primitive", "size", "tolerance") if k not in item]
            if missing:
                raise FormatError(f"{where}: missing {', '.join(missing)}", source)
            if item["primitive"] not in PRIMITIVES:
                raise FormatError(
                    f"{where}: unknown primitive {item['primitive']!r} "
                    f"(one of {', '.join(PRIMITIVES)})",
                    source,
                )
            try:
                size = tuple(float(v) for v in item["size"])
                tol = item["tolerance"]
                tol = (
                    tuple(float(v) for v in tol)
                    if isinstance(tol, Sequence)
                    else (float(tol),) * len(size)
                )
            except (TypeError, ValueError):
                raise FormatError(f"{where}: size and tolerance must be numbers", source) from None
            if len(size) != 3 or len(tol) != 3 or min(tol) <= 0 or min(size) < 0:
                raise FormatError(
                    f"{where}: size needs 3 values >= 0 and tolerance 3 values > 0", source
                )
            rules.append(ClassificationRule(str(item["type"]), item["primitive"], size, tol))
        return cls(rules)

    @classmethod
    def load(cls, path: str | Path) -> RuleSet:
        return cls.from_data(load_yaml(path), str(path))

    def classify(self, primitive: str, size: np.ndarray) -> tuple[str, float]:
        """``(type, normalised error)``; ``("unknown", inf)`` when no rule matches."""
        best, err = "unknown", np.inf
        for rule in self.rules:
            e = rule.error(primitive, size)
            if e <= 1.0 and e < err:
                best, err = rule.type, e
        return best, err
