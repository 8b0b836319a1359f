"""From recognised motion primitives to the human actions of the Task Manager.

The recogniser names what the wrist did (``pour_water``, ``pick_up`` ...); the Task Manager's
action schemas name what the human did to the task (``pick_up``, ``put_down``, ``screw`` ...).
:class:`ActionMapping` is that translation, given as data (a dict or a YAML/JSON file)::

    mapping:
      pick_leg: pick_up
      place_leg: put_down
      screw_leg: screw
    min_confidence: 0.2        # optional: drop weaker recognitions

:class:`HumanActionPublisher` glues an :class:`OnlineRecognizer` to a callback (e.g. the Task
Manager's "human did X" entry point): feed it samples, it calls
``callback(task_action_name, recognised_action)`` for every mapped recognition.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from flexhrc.errors import FormatError, UnknownNameError
from flexhrc.perception._io import load_yaml
from flexhrc.perception.human.online import OnlineRecognizer, RecognisedAction


@dataclass(frozen=True)
class ActionMapping:
    """Recognised action name → Task-Manager human action name (unmapped names are dropped)."""

    mapping: Mapping[str, str] = field(default_factory=dict)
    min_confidence: float = 0.0

    @classmethod
    def identity(cls, names: Iterable[str]) -> ActionMapping:
        return cls({n: n for n in names})

    @classmethod
    def from_dict(cls, data: Mapping[str, object], source: str = "<dict>") -> ActionMapping:
        if not isinstance(data, Mapping):
            raise FormatError("an action mapping must be a mapping", source)
        raw = data.get("mapping", data)
        if not isinstance(raw, Mapping):
            raise FormatError("'mapping' must map recognised names to task actions", source)
        mapping: dict[str, str] = {}
        for k, v in raw.items():
            if k == "min_confidence" and "mapping" not in data:
                continue
            if not isinstance(v, str) or not v:
                raise FormatError(f"action {k!r} must map to a non-empty name, got {v!r}", source)
            mapping[str(k)] = v
        conf = data.get("min_confidence", 0.0)
        if not isinstance(conf, int | float) or not 0 <= conf <= 1:
            raise FormatError(f"min_confidence must be in [0, 1], got {conf!r}", source)
        return cls(mapping, float(conf))

    @classmethod
    def load(cls, path: str | Path) -> ActionMapping:
        return cls.from_dict(load_yaml(path) or {}, str(path))

    def check(self, known: Iterable[str]) -> None:
        """Raise if the mapping names actions the recogniser does not know."""
        known = set(known)
        unknown = sorted(set(self.mapping) - known)
        if unknown:
            raise UnknownNameError(
                f"the action mapping names unknown actions {', '.join(unknown)} "
                f"(the model knows: {', '.join(sorted(known))})"
            )

    def map(self, action: RecognisedAction | str) -> str | None:
        if isinstance(action, RecognisedAction):
            if action.confidence < self.min_confidence:
                return None
            return self.mapping.get(action.name)
        return self.mapping.get(action)


class HumanActionPublisher:
    """Recognises actions in a sample stream and publishes the mapped Task-Manager actions."""

    def __init__(
        self,
        online: OnlineRecognizer,
        mapping: ActionMapping,
        callback: Callable[[str, RecognisedAction], None],
    ):
        mapping.check(online.recognizer.classes_)
        self.online = online
        self.mapping = mapping
        self.callback = callback

    def _publish(self, recognised: list[RecognisedAction]) -> list[tuple[str, RecognisedAction]]:
        done = []
        for r in recognised:
            name = self.mapping.map(r)
            if name is not None:
                self.callback(name, r)
                done.append((name, r))
        return done

    def push(self, samples: np.ndarray) -> list[tuple[str, RecognisedAction]]:
        return self._publish(self.online.push(samples))

    def finish(self) -> list[tuple[str, RecognisedAction]]:
        return self._publish(self.online.finish())
