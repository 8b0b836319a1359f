"""The table-setting scenarios of paper 002 (Fraser et al., Figs. 1–6).

* ``table-setting`` — the task of Fig. 2: placemat first, then, in any order, the plate before the
  bowl, the fork, the spoon, the knife and one of wine glass / cup / soda can::

      (THEN placemat (AND (THEN plate bowl) fork spoon knife (OR wineglass cup soda_can)))

  with three object layouts (``--layout 1..3``, the setups of Fig. 3). The coordinates are ours:
  the paper only shows photographs, so each layout is built so that the nearest-first choice that
  the activation potential 1/distance produces reproduces the order the paper reports for that
  run (Fig. 4). Nothing in the network knows these orders; :data:`PAPER_ORDERS` is only used to
  compare.
* ``table-setting-robustness`` — Fig. 6: the same task; the fork is moved while the robot reaches
  for it, then the knife. Validity checking resets each interrupted behaviour, the robot takes
  another allowed object, and comes back to the moved ones later.
* ``abstract`` — the abstract task of Fig. 1, ``(THEN a (AND (THEN b c) (OR d e (THEN f g))))``,
  in a generated world (objects at seeded random positions).

The layouts are YAML task files under ``flexhrc/scenario/builtin/data/table_setting/`` and can
be run directly with ``flexhrc behave path/to/layout1.yaml``.
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources

from flexhrc.behavior.task import Task, parse_prefix
from flexhrc.behavior.taskfile import load_task_document
from flexhrc.behavior.world import TabletopWorld, random_world
from flexhrc.errors import FlexhrcError, UnknownNameError

TABLE_SETTING_TASK = (
    "(THEN placemat (AND (THEN plate bowl) fork spoon knife (OR wineglass cup soda_can)))"
)
ABSTRACT_TASK = "(THEN a (AND (THEN b c) (OR d e (THEN f g))))"
LAYOUTS = (1, 2, 3)

#: The orders reported in the paper (Sec. IV) for the three layouts.
PAPER_ORDERS: dict[int, list[str]] = {
    1: ["placemat", "plate", "wineglass", "bowl", "spoon", "knife", "fork"],
    2: ["placemat", "wineglass", "plate", "bowl", "knife", "fork", "spoon"],
    3: ["placemat", "wineglass", "plate", "knife", "bowl", "spoon", "fork"],
}

SCENARIOS = ("table-setting", "table-setting-robustness", "abstract")


@dataclass
class Scenario:
    name: str
    task: Task
    world: TabletopWorld
    description: str
    layout: int | None = None


def _data_file(name: str) -> tuple[str, str]:
    ref = resources.files("flexhrc.scenario.builtin") / "data" / "table_setting" / name
    return ref.read_text(encoding="utf-8"), str(ref)


def table_setting_task() -> Task:
    return parse_prefix(TABLE_SETTING_TASK, "table-setting")


def _load(file: str, arms: int) -> tuple[Task, TabletopWorld]:
    text, source = _data_file(file)
    doc = load_task_document(text, source, arms=arms if arms != 1 else None)
    if doc.world is None:  # pragma: no cover - the packaged files all have a world
        raise FlexhrcError(f"{source}: no world")
    if doc.task.to_prefix() != TABLE_SETTING_TASK:
        raise FlexhrcError(f"{source}: task differs from the table-setting task")
    return doc.task, doc.world


def table_setting(layout: int = 1, arms: int = 1) -> Scenario:
    if layout not in LAYOUTS:
        raise FlexhrcError(f"table-setting has layouts 1, 2 and 3; got --layout {layout}")
    task, world = _load(f"layout{layout}.yaml", arms)
    return Scenario(
        "table-setting",
        task,
        world,
        f"Table setting (Fig. 2), object layout {layout} (Fig. 3)",
        layout,
    )


def table_setting_robustness(arms: int = 1) -> Scenario:
    task, world = _load("robustness.yaml", arms)
    return Scenario(
        "table-setting-robustness",
        task,
        world,
        "Table setting with objects moved while being grasped (Fig. 6)",
    )


def abstract(seed: int = 0, arms: int = 1) -> Scenario:
    task = parse_prefix(ABSTRACT_TASK, "abstract")
    return Scenario(
        "abstract", task, random_world(task.behaviors, seed, arms), "Abstract task of Fig. 1"
    )


def load_scenario(name: str, layout: int | None = None, arms: int = 1, seed: int = 0) -> Scenario:
    """A scenario by CLI name; ``layout`` only applies to ``table-setting`` (default 1)."""
    if arms not in (1, 2):
        raise FlexhrcError(f"--arms must be 1 or 2, got {arms}")
    if name == "table-setting":
        return table_setting(1 if layout is None else layout, arms)
    if layout is not None:
        raise FlexhrcError(f"--layout only applies to the table-setting scenario, not {name!r}")
    if name == "table-setting-robustness":
        return table_setting_robustness(arms)
    if name == "abstract":
        return abstract(seed, arms)
    raise UnknownNameError(f"unknown scenario {name!r} (known: {', '.join(SCENARIOS)})")
