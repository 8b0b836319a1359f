"""Sensing: the glue that lets perception look at the action level's simulated world.

``flexhrc.perception`` knows depth images, point clouds and wrist signals; ``flexhrc.action``
knows the robot and its simulated workspace. This package sits above both (and above the Task
Manager) and joins them, so neither imports the other:

* :mod:`.world` — :class:`SimulatedWorkspace`, the parts as they physically are;
* :mod:`.camera` — :class:`HeadCamera`, PyBullet depth images of it from the robot's head;
* :mod:`.perception` — :class:`PerceptionComponent`, render -> scene pipeline -> anchoring;
* :mod:`.har_real` — :class:`HmpReplaySensor`, the operator's wrist signal replayed from real
  HMP trials;
* :mod:`.agent` — :class:`PerceptionAgent`, the head camera as an agent of a cell;
* :mod:`.loop` — :class:`PerceivedCell`, the cell configured so that its manager knows the world
  only through these sensors (validity during execution, inconsistency repair), and
  :class:`WorkspaceTruth`, the workspace the agents' actions change;
* :mod:`.setup` — :func:`perceived_run`, that configuration from a scenario's graph, domain and
  world;
* :mod:`.figure` — the picture of one frame and its detections (``flexhrc scene frame``).

Everything here needs the ``sim`` and ``perception`` extras; nothing is imported eagerly.
"""

from __future__ import annotations

__all__: list[str] = []
