"""The operator panel (``flexhrc[web]``): the cooperation seen and driven from a browser.

* :mod:`flexhrc.web.backend` — the :class:`PanelBackend` contract and request validation;
* :mod:`flexhrc.web.snapshot` — the JSON state (graph statuses, suggestions) of a Task Manager;
* :mod:`flexhrc.web.live` — :class:`~flexhrc.web.live.CellPanel`, the backend over a
  :class:`flexhrc.cell.Cell` (the one loop), polled by the cell's loop;
* :mod:`flexhrc.web.local` — :func:`serve_panel` (``flexhrc panel``): a cell in this process with
  simulated arms on the wall clock and the person at the page as its operator;
* :mod:`flexhrc.web.app` — the ASGI app (Starlette; needs the ``web`` extra);
* :mod:`flexhrc.web.server` — ``--web HOST:PORT``, the loopback rule, :class:`PanelServer`.

The page, its script and style are package data under ``static/``: nothing is loaded from the
network. See ``docs/panel.md``.
"""

from typing import TYPE_CHECKING, Any

from flexhrc.web.backend import PanelBackend, PanelInputError

if TYPE_CHECKING:
    from flexhrc.web.local import LocalPanel, PanelConfig, PanelReport, serve_panel

_LOCAL = ("LocalPanel", "PanelConfig", "PanelReport", "serve_panel")


def __getattr__(name: str) -> Any:
    # the panel's cell loads the Task Manager and its graph: only when it is asked for
    if name in _LOCAL:
        from flexhrc.web import local

        return getattr(local, name)
    raise AttributeError(f"module 'flexhrc.web' has no attribute {name!r}")


__all__ = [
    "LocalPanel",
    "PanelBackend",
    "PanelConfig",
    "PanelInputError",
    "PanelReport",
    "serve_panel",
]
