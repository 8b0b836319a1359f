"""flexhrc — flexible human-robot collaboration.

A task is written once as a hierarchical, first-order AND/OR graph (or as a THEN/AND/OR
behaviour network). At run time flexhrc tracks where the cooperation stands, tells the human
what would be cheapest to do next, decides which robot arm does what by simulating the
candidates, and adapts when the human does something else or a robot action fails.

Sub-packages follow the loop of the FlexHRC+ architecture, on floors that import only downwards
(see ``docs/architecture.md``): ``logic``, ``transport``, ``knowledge``, ``representation``,
``perception``, ``taskmanager``, ``behavior``, ``action``, ``scenarios``, ``scenario``, ``cell``,
``sensing``, ``web``, ``ros2`` and ``cli``. Importing :mod:`flexhrc` itself is cheap.
"""

from flexhrc.errors import FlexhrcError, FormatError

__version__ = "0.1.0.dev0"

__all__ = ["FlexhrcError", "FormatError", "__version__"]
