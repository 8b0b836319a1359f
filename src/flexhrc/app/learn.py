"""``flexhrc learn STORE... -o operators.yaml`` as one library call (issue 22, item 4).

The operator model itself — what it holds, its file, how the Task Manager uses it — is
:mod:`flexhrc.taskmanager.operator_model`; this reads the cell's event stores into it.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from flexhrc.cell.store import read_store
from flexhrc.taskmanager.operator_model import OperatorModel, learn_events


def learn_model(stores: Sequence[str | Path]) -> OperatorModel:
    """The model of every person in ``stores`` (cell event stores, read-only, in order): a file
    that is not a store is one :class:`~flexhrc.errors.FormatError` naming it."""
    model = OperatorModel()
    for path in stores:
        learn_events(read_store(path), model)
        model.stores.append(str(path))
    return model


__all__ = ["learn_model"]
