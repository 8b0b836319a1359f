"""Plain words for the person (issue 24, item 1): an action's ``text:`` with its objects filled
in, a readable fallback from its name, and the key checked where a scenario is read."""

from __future__ import annotations

import pytest

from flexhrc.errors import FormatError
from flexhrc.taskmanager.domain import Domain, GroundAction
from flexhrc.taskmanager.words import plain_words, readable

AGENTS = {
    "human": {"kind": "human", "types": ["human"]},
    "left": {"kind": "robot", "types": ["arm"]},
}


def _domain(**action: object) -> Domain:
    schema = {
        "parameters": {"?who": "agent", "?obj": "leg", "?to": "place"},
        "agents": {"choice": "?who"},
        **action,
    }
    return Domain.from_dict({"agents": AGENTS, "actions": {"screw": schema}}, "d.yaml")


@pytest.mark.parametrize(
    ("name", "words"),
    [
        ("bolt_1", "bolt 1"),
        ("leg3", "leg 3"),
        ("human_from_middle_1", "human from middle 1"),
        ("box", "box"),
        ("top-left", "top left"),
    ],
)
def test_readable_names(name: str, words: str) -> None:
    assert readable(name) == words


def test_the_text_of_an_action_is_filled_in() -> None:
    d = _domain(text="Screw {?obj} into {?to}")
    act = GroundAction(d.schema("screw"), ("human", "leg3", "bolt_1"), ("human",))
    assert plain_words(act) == "Screw leg 3 into bolt 1"


def test_without_a_text_the_name_and_objects_speak_and_agents_are_left_out() -> None:
    d = _domain()
    act = GroundAction(d.schema("screw"), ("left", "leg3", "bolt_1"), ("left",))
    assert plain_words(act) == "Screw leg 3, bolt 1"
    assert plain_words(act, ("human", "left")) == "Screw leg 3, bolt 1"


def test_a_text_naming_no_parameter_is_one_error_at_its_line() -> None:
    with pytest.raises(FormatError, match=r"text names \{\?bolt\}, not one of its parameters"):
        _domain(text="Screw {?obj} into {?bolt}")
    with pytest.raises(FormatError, match="text must be plain words"):
        _domain(text=3)


def test_an_unknown_key_of_an_action_is_an_error_with_the_near_name() -> None:
    with pytest.raises(FormatError, match=r"unknown key 'txt' \(did you mean 'text'\?\)"):
        _domain(txt="Screw it")
