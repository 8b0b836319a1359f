"""An operator model learned from the event store: how long each person takes, how often they
say no.

The Task Manager scores a branch by simulating it (paper 000, V-A): ``J(b) = success(b) /
sum(t_i)`` (eq. 21). For a robot arm the simulator's times are a model of the arm; for a person
they are the scenario's nominal figures (``Timing``, a domain's ``duration``), the same for every
operator. An :class:`OperatorModel` holds what the store says about each *person* instead: per
person and action, the durations they really took — median and spread, the median being what
the branch simulation uses — and the share of suggestions they declined or could not do, in
all and per action name (a person who cannot carry may still screw).

* :func:`learn_events` reads the events of stores (``flexhrc learn STORE... -o FILE``,
  :func:`flexhrc.app.learn.learn_model`): a ``human_action`` input whose body carries ``start``
  and ``t`` is one duration sample of its ``agent`` for its action's name; ``suggestion``
  outputs count what each person was asked (in all and per action name it holds), and their
  ``human_reply`` inputs how often they declined or could not (the request's names too).
* :class:`OperatorModelSimulator` wraps any :class:`~flexhrc.taskmanager.simulator.Simulator`:
  a step done by a person whom the model knows for that action lasts the model's median; every
  other step, and the simulated *real* world (``execute``), are the wrapped simulator's own.
* :meth:`OperatorModelSimulator.answer_odds`: how likely the people of a branch are to say
  "not now" or "I can't" when asked (their learned rates). The Task Manager scores a branch
  that needs a person by its *expected* utility: eq. (21) times the chance that the person does
  it when asked, ``E[J(b)] = J(b) * prod_p (1 - p_decline(p) - p_cannot(p))``, each person's
  rates those of the branch's action they refused most (:meth:`PersonModel.rates`) — a branch the
  person would likely refuse is worth less than its time alone says (a refusal costs the
  answer's delay and a second decision). Its terms ``p_decline``, ``p_cannot`` go to the
  decision log beside ``success``, ``time`` and ``utility``. Without a model, or for a branch
  whose people have no such answers in the model, the score is eq. (21) unchanged and no
  terms are logged.
* Online update: the cell hands every ``human_action`` input it feeds the manager to
  :meth:`OperatorModelSimulator.observe_human_action`, live and when a store is replayed
  (``--resume``), so the estimate moves as the cooperation goes on, reproducibly.

The file format (``docs/operators.md``) is a contract: :func:`read_model` refuses a bad file
with one :class:`~flexhrc.errors.FormatError` naming the file and line.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeGuard

from flexhrc.errors import FormatError
from flexhrc.knowledge import KnowledgeBase
from flexhrc.taskmanager.domain import Domain, GroundAction
from flexhrc.taskmanager.simulator import SimulationResult, Simulator

#: The format's version, the value of the file's ``flexhrc_operators`` key.
FORMAT_VERSION = 1
#: How many of the latest samples an estimate keeps (and the file lists): a person changes —
#: they learn the task, they tire — so the median follows the recent ones.
WINDOW = 50
#: The person's answers that count (issue 22, item 1): a stored ``human_reply`` input whose
#: ``reply`` is "not now" (an unanswered suggestion's timeout is stored as one) or "I can't".
DECLINE, CANNOT = "decline", "cannot"
REPLY_KIND = "human_reply"


@dataclass
class ActionEstimate:
    """What one person's durations of one action were: the latest samples (at most
    :data:`WINDOW`, oldest first), their median and spread (median absolute deviation)."""

    samples: list[float] = field(default_factory=list)

    @property
    def n(self) -> int:
        return len(self.samples)

    @property
    def median_s(self) -> float:
        return statistics.median(self.samples) if self.samples else 0.0

    @property
    def spread_s(self) -> float:
        """Median absolute deviation from the median (s): robust to one slow outlier."""
        if not self.samples:
            return 0.0
        m = self.median_s
        return statistics.median(abs(s - m) for s in self.samples)

    def add(self, seconds: float) -> None:
        self.samples.append(float(seconds))
        del self.samples[:-WINDOW]

    def to_dict(self) -> dict[str, Any]:
        return {
            "n": self.n,
            "median_s": round(self.median_s, 4),
            "spread_s": round(self.spread_s, 4),
            "samples_s": [round(s, 4) for s in self.samples],
        }


class _Answered:
    """The rates of a person's answers (:class:`AnswerCounts`, :class:`PersonModel`)."""

    suggestions: int
    declined: int
    cannot: int

    @property
    def decline_rate(self) -> float:
        return self.declined / self.suggestions if self.suggestions else 0.0

    @property
    def cannot_rate(self) -> float:
        return self.cannot / self.suggestions if self.suggestions else 0.0

    def _answers_dict(self) -> dict[str, Any]:
        return {
            "suggestions": self.suggestions,
            "declined": self.declined,
            "cannot": self.cannot,
            "decline_rate": round(self.decline_rate, 4),
            "cannot_rate": round(self.cannot_rate, 4),
        }


@dataclass
class AnswerCounts(_Answered):
    """How many requests with one action a person got, declined and could not do."""

    suggestions: int = 0
    declined: int = 0
    cannot: int = 0

    def to_dict(self) -> dict[str, Any]:
        return self._answers_dict()


@dataclass
class PersonModel(_Answered):
    """One person: an estimate per action name; how many suggestions they got, declined and
    answered with "I can't" (the rates are 0 until such answers are stored), in all and per
    action name (``answers``: the requests that held an action of that name)."""

    actions: dict[str, ActionEstimate] = field(default_factory=dict)
    suggestions: int = 0
    declined: int = 0
    cannot: int = 0
    answers: dict[str, AnswerCounts] = field(default_factory=dict)

    @property
    def has_answered(self) -> bool:
        """Whether the person ever declined or said "I can't" (in all, or for an action)."""
        return bool(
            self.declined
            or self.cannot
            or any(c.declined or c.cannot for c in self.answers.values())
        )

    def rates(self, action: str) -> tuple[float, float]:
        """(decline rate, cannot rate) of a request with ``action`` (an action's name): its
        own when the person was asked one, else the person's over all their requests."""
        counts = self.answers.get(action)
        if counts is not None and counts.suggestions:
            return counts.decline_rate, counts.cannot_rate
        return self.decline_rate, self.cannot_rate

    def to_dict(self) -> dict[str, Any]:
        return {
            "actions": {a: e.to_dict() for a, e in sorted(self.actions.items())},
            **self._answers_dict(),
            **(
                {"answers": {a: c.to_dict() for a, c in sorted(self.answers.items())}}
                if self.answers
                else {}
            ),
        }


@dataclass
class OperatorModel:
    """Per person (the domain's human agent name), per action: see the module docstring."""

    persons: dict[str, PersonModel] = field(default_factory=dict)
    stores: list[str] = field(default_factory=list)  # what it was learned from

    def person(self, name: str) -> PersonModel:
        return self.persons.setdefault(name, PersonModel())

    def estimate(self, person: str, action: str, kind: str | None = None) -> ActionEstimate | None:
        """The estimate of ``person`` doing ``action`` (an action's name), else of its ``kind``
        (an entry written by hand for every action of a kind); None when the model has none."""
        p = self.persons.get(person)
        if p is None:
            return None
        for key in (action, kind):
            est = p.actions.get(key) if key else None
            if est is not None and est.n:
                return est
        return None

    def observe(self, person: str, action: str, seconds: float) -> None:
        """One more duration sample (an online update)."""
        if math.isfinite(seconds) and seconds >= 0:
            self.person(person).actions.setdefault(action, ActionEstimate()).add(seconds)

    def observe_human_action(self, body: Mapping[str, Any]) -> bool:
        """A ``human_action`` input (store body or protocol message) as a sample: its
        ``agent``, its action's name and ``t - start``. Without a numeric ``start`` (a panel
        ``done`` that said no start time) it tells nothing; returns whether it was used."""
        start, end, agent = body.get("start"), body.get("t"), body.get("agent")
        text = body.get("action")
        numbers = all(isinstance(v, int | float) and not isinstance(v, bool) for v in (start, end))
        if not (numbers and isinstance(agent, str) and isinstance(text, str)):
            return False
        if body.get("recognised") is False:  # the sensor missed it: the manager never knew
            return False
        seconds = float(end) - float(start)  # type: ignore[arg-type]
        if not (math.isfinite(seconds) and seconds >= 0):
            return False
        self.observe(agent, action_name(text), seconds)
        return True

    def to_dict(self) -> dict[str, Any]:
        return {
            "flexhrc_operators": FORMAT_VERSION,
            "learned_from": list(self.stores),
            "persons": {n: p.to_dict() for n, p in sorted(self.persons.items())},
        }

    def to_yaml(self) -> str:
        import yaml

        header = (
            "# flexhrc operator model (docs/operators.md): per person and action, the durations\n"
            "# they took (median, spread = median absolute deviation, the latest samples) and\n"
            "# the share of suggestions they declined or could not do (in all, and per action).\n"
        )
        return header + yaml.safe_dump(self.to_dict(), sort_keys=False, default_flow_style=None)


def action_name(text: str) -> str:
    """``screw`` from ``screw(human, leg3, bolt_1)``."""
    return text.split("(", 1)[0].strip()


def _answer(kind: str, body: Mapping[str, Any]) -> str | None:
    """``decline``/``cannot`` if this event is such an answer of a person (:data:`REPLY_KIND`)."""
    if kind != REPLY_KIND:
        return None
    reply = body.get("reply")
    return reply if reply in (DECLINE, CANNOT) else None


def learn_events(events: Iterable[Any], model: OperatorModel | None = None) -> OperatorModel:
    """Add what ``events`` (:class:`~flexhrc.cell.store.StoredEvent` rows of one or more runs)
    say about each person to ``model`` (a new one by default) and return it."""
    model = model if model is not None else OperatorModel()
    seen: set[tuple[str, str]] = set()  # (run, human_action id): a resent report counts once
    asked: dict[tuple[str, str], list[str]] = {}  # (run, suggestion id) -> its action names
    for ev in events:
        body = ev.body
        run = str(body.get("run", ""))
        if ev.kind == "human_action":
            key = (run, str(body.get("id")))
            if key not in seen:
                seen.add(key)
                model.observe_human_action(body)
        elif ev.kind == "suggestion" and isinstance(body.get("agent"), str):
            p = model.person(body["agent"])
            p.suggestions += 1
            names = _action_names(body.get("actions"))
            asked[(run, str(body.get("id")))] = names
            for name in names:
                p.answers.setdefault(name, AnswerCounts()).suggestions += 1
        else:
            answer = _answer(ev.kind, body)
            key = (run, f"reply:{body.get('id')}")
            if answer is not None and isinstance(body.get("agent"), str) and key not in seen:
                seen.add(key)
                p = model.person(body["agent"])
                field_ = "declined" if answer == DECLINE else "cannot"
                setattr(p, field_, getattr(p, field_) + 1)
                # the request it answered, by its actions (a reply naming none: the person's)
                for name in asked.get((run, str(body.get("suggestion"))), []):
                    counts = p.answers.get(name)
                    if counts is not None:
                        setattr(counts, field_, getattr(counts, field_) + 1)
    return model


def _action_names(actions: Any) -> list[str]:
    """The distinct action names of a request's ``actions`` (in order)."""
    if not isinstance(actions, list):
        return []
    return list(dict.fromkeys(action_name(a) for a in actions if isinstance(a, str)))


# -- the file ------------------------------------------------------------------------------------


def read_model(path: str | Path) -> OperatorModel:
    """An operator model file (``docs/operators.md``); a bad one is one :class:`FormatError`
    with the file and line."""
    from flexhrc.representation.formats.yaml_format import read_yaml

    p = Path(path)
    return model_from_dict(read_yaml(p), p)


def model_from_dict(doc: Any, source: str | Path) -> OperatorModel:
    """The model a document of the file's form holds (:meth:`OperatorModel.to_dict`: a file
    read, or the copy a cell keeps in its stored ``start``); a bad one is one
    :class:`FormatError` naming ``source`` (and the line, for a file read)."""
    p = source

    def line(d: Any, key: Any = None) -> int | None:
        lines = getattr(d, "lines", None)
        if key is not None and isinstance(lines, dict) and key in lines:
            return int(lines[key])
        return getattr(d, "line", None) or None

    def fail(message: str, d: Any = None, key: Any = None) -> FormatError:
        return FormatError(message, p, line(d, key) if d is not None else None)

    if not isinstance(doc, dict):
        raise fail("an operator model must be a mapping with flexhrc_operators: 1", doc)
    allowed = {"flexhrc_operators", "learned_from", "persons"}
    for k in doc:
        if k not in allowed:
            raise fail(f"unknown key {k!r} (expected {', '.join(sorted(allowed))})", doc, k)
    if doc.get("flexhrc_operators") != FORMAT_VERSION:
        raise fail(
            f"flexhrc_operators must be {FORMAT_VERSION} (the format's version), got "
            f"{doc.get('flexhrc_operators')!r}",
            doc,
            "flexhrc_operators",
        )
    model = OperatorModel()
    learned = doc.get("learned_from", [])
    if not isinstance(learned, list) or not all(isinstance(s, str) for s in learned):
        raise fail("learned_from must be a list of file names", doc, "learned_from")
    model.stores = list(learned)
    persons = doc.get("persons", {})
    if persons is None:
        persons = {}
    if not isinstance(persons, dict):
        raise fail("persons must be a mapping: person -> their model", doc, "persons")
    for name, pd in persons.items():
        if not isinstance(name, str) or not name:
            raise fail(f"person {name!r}: a name (the domain's human agent)", persons, name)
        if not isinstance(pd, dict):
            raise fail(
                f"person {name}: must be a mapping (actions, suggestions ...)", persons, name
            )
        model.persons[name] = _person(pd, name, fail)
    return model


_PERSON_KEYS = {
    "actions", "suggestions", "declined", "cannot", "decline_rate", "cannot_rate", "answers",
}  # fmt: skip
_COUNT_KEYS = {"suggestions", "declined", "cannot", "decline_rate", "cannot_rate"}
_ACTION_KEYS = {"n", "median_s", "spread_s", "samples_s"}


def _number(v: Any) -> TypeGuard[float]:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def _person(pd: Any, name: str, fail: Any) -> PersonModel:
    for k in pd:
        if k not in _PERSON_KEYS:
            raise fail(f"person {name}: unknown key {k!r}", pd, k)
    person = PersonModel()
    _counts(person, pd, f"person {name}", fail)
    answers = pd.get("answers", {}) or {}
    if not isinstance(answers, dict):
        raise fail(f"person {name}: answers must be a mapping: action -> counts", pd, "answers")
    for action, ad in answers.items():
        where = f"person {name}, answers {action}"
        if not isinstance(action, str) or not action:
            raise fail(f"person {name}: answers: an action must be named", answers, action)
        if not isinstance(ad, dict):
            raise fail(f"{where}: must be a mapping (suggestions, declined ...)", answers, action)
        for k in ad:
            if k not in _COUNT_KEYS:
                raise fail(f"{where}: unknown key {k!r}", ad, k)
        person.answers[action] = _counts(AnswerCounts(), ad, where, fail)
    actions = pd.get("actions", {}) or {}
    if not isinstance(actions, dict):
        raise fail(f"person {name}: actions must be a mapping: action -> estimate", pd, "actions")
    for action, ad in actions.items():
        where = f"person {name}, action {action}"
        if not isinstance(action, str) or not action:
            raise fail(f"person {name}: an action must be named", actions, action)
        if not isinstance(ad, dict):
            raise fail(f"{where}: must be a mapping (n, median_s ...)", actions, action)
        for k in ad:
            if k not in _ACTION_KEYS:
                raise fail(f"{where}: unknown key {k!r}", ad, k)
        samples = ad.get("samples_s")
        if samples is not None:
            ok = isinstance(samples, list) and all(_number(s) and s >= 0 for s in samples)
            if not ok:
                raise fail(f"{where}: samples_s must be a list of seconds >= 0", ad, "samples_s")
            values = [float(s) for s in samples]
        else:
            median, n = ad.get("median_s"), ad.get("n", 1)
            if not (_number(median) and median >= 0):
                raise fail(
                    f"{where}: median_s must be seconds >= 0, got {median!r}", ad, "median_s"
                )
            if not (isinstance(n, int) and not isinstance(n, bool) and n >= 1):
                raise fail(f"{where}: n must be a whole number >= 1, got {n!r}", ad, "n")
            # a hand-written estimate counts as n samples of its median
            values = [float(median)] * min(n, WINDOW)
        for k in ("median_s", "spread_s"):
            v = ad.get(k)
            if v is not None and not (_number(v) and v >= 0):
                raise fail(f"{where}: {k} must be seconds >= 0, got {v!r}", ad, k)
        person.actions[action] = ActionEstimate(values[-WINDOW:])
    return person


def _counts(into: Any, d: Any, where: str, fail: Any) -> Any:
    """``suggestions``, ``declined``, ``cannot`` (and the derived rates, checked) of ``d``
    into ``into`` (a :class:`PersonModel` or :class:`AnswerCounts`)."""
    for k in ("suggestions", "declined", "cannot"):
        v = d.get(k, 0)
        if not (isinstance(v, int) and not isinstance(v, bool) and v >= 0):
            raise fail(f"{where}: {k} must be a whole number >= 0, got {v!r}", d, k)
        setattr(into, k, v)
    for k in ("decline_rate", "cannot_rate"):  # derived; checked so a typo does not pass
        v = d.get(k, 0.0)
        if not (_number(v) and 0 <= v <= 1):
            raise fail(f"{where}: {k} must be a number in [0, 1], got {v!r}", d, k)
    if into.declined + into.cannot > into.suggestions:
        key = "declined" if "declined" in d else "cannot"  # a line the reader can find
        raise fail(f"{where}: more answers (declined + cannot) than suggestions", d, key)
    return into


def write_model(model: OperatorModel, path: str | Path) -> None:
    """Write ``model`` to ``path`` atomically (a reader never sees half a file)."""
    from flexhrc.files import atomic_write_text

    atomic_write_text(path, model.to_yaml())


# -- the branch simulation ---------------------------------------------------------------------


class OperatorModelSimulator:
    """A :class:`~flexhrc.taskmanager.simulator.Simulator` whose steps done by a person last
    what the :class:`OperatorModel` says that person takes (its median), see the module
    docstring. Everything else — robot steps, success, positions, the kinematic model's joint
    state, ``execute`` (the simulated real world) — is the wrapped simulator's."""

    def __init__(self, inner: Simulator, model: OperatorModel) -> None:
        self.inner = inner
        self.model = model
        self.replaced = 0  # how many human step times the model gave

    @property
    def name(self) -> str:
        from flexhrc.taskmanager.simulator import simulator_name

        return simulator_name(self.inner)

    def __getattr__(self, attr: str) -> Any:
        # set_joint_state, simulated, execute ...: the wrapped simulator's (only reached for
        # attributes this class does not define)
        if attr in ("inner", "model"):
            raise AttributeError(attr)
        return getattr(self.inner, attr)

    def simulate(
        self, steps: Sequence[GroundAction], kb: KnowledgeBase, domain: Domain
    ) -> SimulationResult:
        result = self.inner.simulate(steps, kb, domain)
        durations = list(result.durations)
        details = [dict(d) for d in result.details]
        for i, action in enumerate(steps[: len(durations)]):
            seconds = self.person_time(action, domain)
            if seconds is None:
                continue
            durations[i] = seconds
            if i < len(details):
                details[i]["t"] = seconds
                details[i]["learned"] = True
        return SimulationResult(result.success, durations, result.reason, details)

    def person_time(self, action: GroundAction, domain: Domain) -> float | None:
        """The model's time of ``action`` when a person it knows does it (the slowest of its
        people, for a joint action), else None (the wrapped simulator's time stands)."""
        from flexhrc.taskmanager.kinds import kind_of

        kind = kind_of(action.schema).name
        times = []
        for name in action.agents:
            if not domain.agent(name).is_human:
                continue
            est = self.model.estimate(name, action.name, kind)
            if est is None:
                return None
            times.append(est.median_s)
        if not times:
            return None
        self.replaced += 1
        return max(times)

    def answer_odds(self, steps: Sequence[GroundAction], domain: Domain) -> dict[str, float] | None:
        """How likely the people of a branch of ``steps`` are to refuse it when asked: the
        sums of their learned ``p_decline`` and ``p_cannot`` — per person the rates of the
        action of the branch they refused most (:meth:`PersonModel.rates`: the action's own,
        else the person's) — and ``p_does``, the chance that every one of them does
        it, ``prod_p (1 - p_decline(p) - p_cannot(p))`` (the factor of the expected utility,
        see the module docstring). None when no person of the branch has declined or said
        "I can't" in the model (eq. 21 stands)."""
        persons: dict[str, list[str]] = {}  # person -> the action names they do in it
        for s in steps:
            for a in s.agents:
                if a in domain.agents and domain.agent(a).is_human:
                    persons.setdefault(a, []).append(s.name)
        declined = cannot = 0.0
        does = 1.0
        known = False
        for name, actions in persons.items():
            p = self.model.persons.get(name)
            if p is None or not p.has_answered:
                continue
            known = True
            # a request is as likely refused as its most refused action (PersonModel.rates)
            rates = [p.rates(a) for a in dict.fromkeys(actions)]
            pd, pc = max(r[0] for r in rates), max(r[1] for r in rates)
            declined += pd
            cannot += pc
            does *= max(0.0, 1.0 - pd - pc)
        if not known:
            return None
        return {"p_decline": round(declined, 6), "p_cannot": round(cannot, 6), "p_does": does}

    def observe_human_action(self, body: Mapping[str, Any]) -> None:
        """The online update: the cell feeds every ``human_action`` input here."""
        self.model.observe_human_action(body)


__all__ = [
    "FORMAT_VERSION",
    "ActionEstimate",
    "AnswerCounts",
    "OperatorModel",
    "OperatorModelSimulator",
    "PersonModel",
    "learn_events",
    "model_from_dict",
    "read_model",
    "write_model",
]
