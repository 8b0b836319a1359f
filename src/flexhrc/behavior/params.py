"""Run-time parameters of the behaviour network and the node states (paper 002, Sec. III-A/D).

Where the paper leaves a choice open it is a parameter here:

* ``tau_active`` (τ_active): a node is *active* while its activation level exceeds it;
* ``falloff`` (α, in (0, 1)): the level is multiplied by α at the end of every update loop
  (Algorithm 1, line 14) so a node its parent stops feeding decays below τ and stops;
* ``and_spread``: Algorithm 3 sends ``1/n`` to each of an AND's ``n`` children; the paper notes a
  large AND may instead send a fixed level. ``"divide"`` always uses 1/n, ``"fixed"`` always
  sends ``and_level``, ``"auto"`` (default) uses 1/n unless that would not exceed τ_active;
* OR ties (Algorithm 4, "the robot will choose one of the options at random") are broken with a
  random generator seeded from ``seed`` and the node name — the same seed gives the same run;
* ``mutex_window``: length of the bidding window the arm mutex opens on a lock request;
* ``validity_threshold``: how far (m) a watched object may move before validity checking resets
  the behaviour;
* ``tick_period``: simulated seconds per update loop;
* ``latched``: the paper's nodes re-send activation and re-bid for a mutex every loop. With
  ``latched=True`` (default) a message *holds* until its sender changes it: a parent sends a held
  activation once (and a release or a new level when it would stop or change), a waiting
  behaviour places a standing bid once (and withdraws it when it would stop bidding). Every node
  sees exactly what it would have seen with the per-tick messages — the runs are identical
  (tested) — but a waiting behaviour has nothing to do and sleeps, so a tick costs what changes,
  not the number of waiting behaviours. ``latched=False`` is the literal per-tick protocol.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

from flexhrc.errors import FlexhrcError


class NodeState(StrEnum):
    """Node state; the paper's Fig. 4 plots these four for every behaviour."""

    INACTIVE = "inactive"
    ACTIVE = "active"
    RUNNING = "running"
    DONE = "done"


AND_SPREAD_MODES = ("auto", "divide", "fixed")


@dataclass(frozen=True)
class NetworkParams:
    tau_active: float = 0.1
    falloff: float = 0.9
    tick_period: float = 0.1
    and_spread: str = "auto"
    and_level: float = 1.0
    mutex_window: float = 0.5
    validity_threshold: float = 0.05
    seed: int = 0
    latched: bool = True

    def __post_init__(self) -> None:
        if not 0 < self.falloff < 1:
            raise FlexhrcError(f"falloff α must be in (0, 1), got {self.falloff}")
        if not 0 <= self.tau_active < 1:
            raise FlexhrcError(f"tau_active must be in [0, 1), got {self.tau_active}")
        if not self.tick_period > 0:
            raise FlexhrcError("tick_period must be > 0")
        if self.and_spread not in AND_SPREAD_MODES:
            raise FlexhrcError(
                f"and_spread must be one of {AND_SPREAD_MODES}, got {self.and_spread!r}"
            )
        if not self.and_level > self.tau_active:
            raise FlexhrcError("and_level must exceed tau_active")
        if self.mutex_window < 0 or self.validity_threshold <= 0:
            raise FlexhrcError("mutex_window must be >= 0 and validity_threshold > 0")

    @property
    def window_ticks(self) -> int:
        """Bidding window in ticks; at least 1 so every bid of a tick is heard before a grant."""
        return max(1, math.ceil(self.mutex_window / self.tick_period - 1e-9))
