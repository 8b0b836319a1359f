"""The manager node's standard ROS 2 interfaces beside the JSON protocol.

:class:`ManagerInterfaces` runs inside the cell's manager process (``flexhrc ros2 cell``), on the
same :class:`~flexhrc.ros2.transport.Ros2Transport`:

========================================  ==================================  =================
topic (under ``/flexhrc/<cell>/``)        type                                direction
========================================  ==================================  =================
``markers``                               ``visualization_msgs/MarkerArray``  out, ``rate_hz``
``objects/<object>/pose``                 ``geometry_msgs/PoseStamped``       in (perception)
``human/<operator>/imu``                  ``sensor_msgs/Imu``                 in (wrist IMU)
========================================  ==================================  =================

* markers: every object of the knowledge base, by its type and size, and, as arrows, the
  targets of the commands running now (:meth:`ManagerInterfaces.command_started`); the arrow
  of a finished command (:meth:`ManagerInterfaces.command_finished`) goes out as a ``DELETE``
  marker with every array for ``DELETE_LINGER_S`` (2 s) after it finished — at least once —
  so RViz removes it even if it matched the topic late; RViz shows the cell as the manager
  believes it is;
* an object pose from perception that runs outside flexhrc becomes a plain dict
  (:func:`~flexhrc.ros2.messages.percept_from_pose`) handed to ``on_percept`` —
  ``flexhrc ros2 cell`` sends it to the manager as the cell protocol's ``percept`` (stored, then
  applied to the knowledge base). Objects are those the scenario declares; a pose for another
  name is not subscribed to;
* wrist IMU readings become samples (:func:`~flexhrc.ros2.messages.imu_sample`) handed to
  ``on_imu(operator, sample)``, for human action recognition.

A message with a non-finite number or a frame other than ``world`` is dropped and logged (counted
in ``dropped``); it never reaches the manager.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Iterable
from typing import Any

from flexhrc.errors import FlexhrcError
from flexhrc.ros2 import messages as rm
from flexhrc.ros2._deps import msg

log = logging.getLogger("flexhrc.ros2.extras")

__all__ = ["DELETE_LINGER_S", "ManagerInterfaces"]

#: How long (wall seconds) a finished command's ``DELETE`` marker is sent again with each array.
DELETE_LINGER_S = 2.0


class ManagerInterfaces:
    """Markers out, object poses and wrist IMU in (see the module docstring)."""

    def __init__(
        self,
        transport: Any,
        kb: Any,
        *,
        objects: Iterable[str] | None = None,
        operators: Iterable[str] = (),
        on_percept: Callable[[dict[str, Any]], None] | None = None,
        on_imu: Callable[[str, dict[str, Any]], None] | None = None,
        rate_hz: float = 2.0,
        clock: Callable[[], float] = time.monotonic,
        skip: Iterable[str] = (),
    ) -> None:
        if not (math.isfinite(rate_hz) and 0 < rate_hz <= 100):
            raise ValueError(f"marker rate must be in (0, 100] Hz, got {rate_hz}")
        self.transport = transport
        self.kb = kb
        self.commands: dict[int, tuple[str, tuple[float, float, float]]] = {}
        self.skip = frozenset(skip)  # the agents' names: not drawn as objects
        # finished commands -> when their DELETE first went out (None: not yet)
        self._finished: dict[int, float | None] = {}
        self.on_percept = on_percept
        self.on_imu = on_imu
        self.period = 1.0 / rate_hz
        self.clock = clock
        self.dropped = 0
        self.percepts = 0
        self.imu_samples = 0
        self._last = -math.inf
        self._markers = transport.create_publisher(
            msg("visualization_msgs.msg", "MarkerArray"), "markers"
        )
        PoseStamped = msg("geometry_msgs.msg", "PoseStamped")
        Imu = msg("sensor_msgs.msg", "Imu")
        names = sorted(objects if objects is not None else kb.objects)
        for name in names:
            transport.create_subscription(
                PoseStamped, f"objects/{name}/pose", lambda m, n=name: self._pose(n, m)
            )
        for op in operators:
            transport.create_subscription(Imu, f"human/{op}/imu", lambda m, o=op: self._imu(o, m))

    def _pose(self, name: str, m: Any) -> None:
        try:
            percept = rm.percept_from_pose(name, m)
            if self.on_percept is not None:  # it builds a protocol percept: checked again
                self.on_percept(percept)
        except (ValueError, FlexhrcError) as exc:
            self.dropped += 1
            log.warning("dropped a pose of %s: %s", name, exc)
            return
        self.percepts += 1

    def _imu(self, operator: str, m: Any) -> None:
        try:
            sample = rm.imu_sample(m)
        except ValueError as exc:
            self.dropped += 1
            log.warning("dropped an IMU reading of %s: %s", operator, exc)
            return
        self.imu_samples += 1
        if self.on_imu is not None:
            self.on_imu(operator, sample)

    def command_started(self, cid: int, label: str, position: Iterable[float] | None) -> None:
        """Command ``cid`` runs, its arm going to ``position`` (an arrow; None: no arrow)."""
        if position is not None:
            x, y, z = (float(v) for v in position)
            self.commands[int(cid)] = (label, (x, y, z))

    def command_finished(self, cid: int) -> None:
        """Command ``cid`` ended (answered or stopped): its arrow is deleted with the next
        markers."""
        self.commands.pop(int(cid), None)
        self._finished.setdefault(int(cid), None)

    def publish_markers(self) -> None:
        now = self.clock()
        for cid, first in list(self._finished.items()):
            if first is None:
                self._finished[cid] = now
            elif now - first > DELETE_LINGER_S:
                del self._finished[cid]
        deleted = set(self._finished)
        markers = rm.marker_array(
            self.kb.objects.values(), time.time(),
            commands=self.commands, deleted=deleted, skip=self.skip,
        )  # fmt: skip
        send = getattr(self.transport, "publish_message", None)
        if send is not None:  # the DELETE markers go once: to every subscriber already known
            send(self._markers, markers)
        else:
            self._markers.publish(markers)
        self._last = self.clock()

    def poll(self) -> None:
        """Publish the markers when they are due."""
        if self.clock() - self._last >= self.period:
            self.publish_markers()
