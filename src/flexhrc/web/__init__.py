"""The operator panel (``flexhrc[web]``): the cooperation seen and driven from a browser.

* :mod:`flexhrc.web.backend` — the :class:`PanelBackend` contract and request validation;
* :mod:`flexhrc.web.snapshot` — the JSON state (graph statuses, suggestions) of a Task Manager;
* :mod:`flexhrc.web.local` — :class:`LocalCooperation`, an in-process cooperation in which the
  operator acts only through the panel;
* :mod:`flexhrc.web.app` — the ASGI app (Starlette; needs the ``web`` extra);
* :mod:`flexhrc.web.server` — ``--web HOST:PORT``, the loopback rule, :class:`PanelServer`.

The page, its script and style are package data under ``static/``: nothing is loaded from the
network. See ``docs/panel.md``.
"""

from flexhrc.web.backend import PanelBackend, PanelInputError

__all__ = ["PanelBackend", "PanelInputError"]
