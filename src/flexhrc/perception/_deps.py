"""Lazy imports of the optional perception dependencies (the ``perception`` extra).

``import flexhrc.perception`` must stay light, so scikit-learn and SciPy are only imported by
the functions that need them, and a missing one becomes an :class:`OptionalDependencyError`
that tells the user which extra to install.
"""

from __future__ import annotations

import importlib
from types import ModuleType

from flexhrc.errors import OptionalDependencyError


def require(module: str, feature: str) -> ModuleType:
    """Import ``module`` or raise :class:`OptionalDependencyError` naming ``feature``."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:  # pragma: no cover - exercised only without the extra
        raise OptionalDependencyError(feature, "perception", module.split(".")[0]) from exc
