"""Validity checking (paper 002, Sec. III-F).

A pick-and-place is time-extended: the arm travels for seconds before the gripper closes. If the
object is moved meanwhile, carrying on would fail. A :class:`ValidityCheck` remembers where the
object was when the behaviour started and, on every tick until the grasp is complete, compares it
with where the world now says it is. A move larger than ``threshold`` metres makes the check
fail; the behaviour then stops the arm, releases the arm mutex and resets itself to *active* (or
*inactive*), so the activation spreading can choose again — possibly another behaviour first.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from flexhrc.behavior.world import TabletopWorld, Vec


@dataclass
class ValidityCheck:
    """Watch one object from the start of a behaviour until it is grasped."""

    object: str
    reference: Vec
    threshold: float = 0.05

    @classmethod
    def watch(cls, world: TabletopWorld, obj: str, threshold: float) -> ValidityCheck:
        return cls(obj, world.object_position(obj), threshold)

    def displacement(self, world: TabletopWorld) -> float:
        if not world.has_object(self.object):
            return math.inf
        return math.dist(world.object_position(self.object), self.reference)

    def valid(self, world: TabletopWorld) -> bool:
        """False on a significant change: the object moved more than the threshold or vanished."""
        return self.displacement(world) <= self.threshold
