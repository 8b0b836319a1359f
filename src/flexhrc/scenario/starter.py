"""The starter scenario ``flexhrc scenario new DIR`` writes: small, commented, and it runs."""

from __future__ import annotations

from pathlib import Path

from flexhrc.errors import FlexhrcError

STARTER_NAME = "scenario.yaml"

STARTER = """\
# A flexhrc scenario: one file says what a cooperation needs (docs/scenarios.md).
#   flexhrc scenario validate scenario.yaml     check it (file:line for every fault)
#   flexhrc run scenario.yaml --human cooperative --seed 1     run it
# The task: a robot arm and an operator put a bracket and a screw on a base plate, then the
# operator tightens the screw. Change the names, add objects and hyper-arcs: validate tells you
# when something does not fit.
flexhrc: 1
name: my_task
description: A bracket and a screw on a base plate, by a robot arm and an operator.

# The AND/OR graph (paper 000, IV): nodes are cooperation states with a state formula, hyper-arcs
# are transitions with the actions A(h) that make them happen. Several hyper-arcs into one node
# are alternatives (OR); the children of one hyper-arc are all needed (AND). Variables (?x) are
# grounded at run time against the world below; the weights make the suggestion costs.
# (A graph may also be a file: graph: my_task.graph.yaml, or the authors' ANDOR text format.)
graphs:
  my_task:
    root: done
    nodes:
      - {name: parts_ready, state: "part(?p) & on_table(?p)"}
      - {name: bracket_placed, state: "placed(bracket)"}
      - {name: screw_placed, state: "placed(bracket) & placed(screw)"}
      - {name: done, state: "tight(screw)"}
    hyperarcs:
      - name: place_bracket
        children: [parts_ready]
        parent: bracket_placed
        weight: 1
        actions: ["pick(?who, bracket)", "place(?who, bracket, plate)"]
      - name: place_screw
        children: [bracket_placed]
        parent: screw_placed
        weight: 1
        actions: ["pick(?who, screw)", "place(?who, screw, plate)"]
      - name: tighten
        children: [screw_placed]
        parent: done
        weight: 1
        actions: ["tighten(human, screw)"]

# Who can act, and the action schemas (eq. 20): typed parameters, preconditions, effects, and
# agents(a) -- one agent, a choice ({choice: ?var}) or several jointly ({joint: [a, b]}).
# duration (s) and moves_to (the parameter the hand goes to) time an action in the analytic
# simulator; carries moves the object with the hand.
domain:
  agents:
    human: {kind: human, types: [human], hand: [1.3, 0.0, 0.1]}   # the operator stands opposite
    arm: {kind: robot, types: [robot], base: [0.0, 0.0, 0.4], rest: [0.3, 0.0, 0.5], reach: 0.9,
          speed: 0.8}                                           # the hand's speed, m/s
  actions:
    pick:
      parameters: {"?who": agent, "?p": part}
      agents: {choice: "?who"}
      pre: ["on_table(?p)", "free(?who)"]
      add: ["holding(?who, ?p)"]
      delete: ["on_table(?p)", "free(?who)"]
      moves_to: "?p"
      duration: 1.0
      undo: put_back
    place:
      parameters: {"?who": agent, "?p": part, "?at": place}
      agents: {choice: "?who"}
      pre: ["holding(?who, ?p)"]
      add: ["placed(?p)", "free(?who)"]
      delete: ["holding(?who, ?p)"]
      moves_to: "?at"
      carries: "?p"
      duration: 1.0
    put_back:
      parameters: {"?who": human, "?p": part}
      agents: {choice: "?who"}
      add: ["on_table(?p)", "free(?who)"]
      delete: ["holding(?who, ?p)"]
      duration: 0.5
    tighten:
      parameters: {"?who": human, "?p": part}
      agents: {choice: "?who"}
      pre: ["placed(?p)"]
      add: ["tight(?p)"]
      moves_to: "?p"
      duration: 3.0

# The world: typed objects with poses (metres; x forward, y left, z up) and sizes, places, the
# facts true at the start (closed world: everything else is false), supertypes.
world:
  objects:
    bracket: {type: part, position: [0.45, 0.25, 0.0], size: [0.08, 0.04, 0.02]}
    screw: {type: part, position: [0.40, -0.25, 0.0], size: [0.03, 0.01, 0.01]}
  places:
    plate: [0.55, 0.0, 0.0]
  facts: ["on_table(bracket)", "on_table(screw)", "free(arm)", "free(human)"]

# The simulated operators: profile passive | takeover | cooperative | random, speed in m/s.
humans:
  - {name: human, profile: cooperative, speed: 0.6}
simulator: analytic
"""


def write_starter(folder: str | Path, *, force: bool = False) -> Path:
    """Write :data:`STARTER` to ``folder/scenario.yaml`` (the folder is created; an existing
    file is kept unless ``force``) and return its path."""
    from flexhrc.files import atomic_write_text

    if not str(folder).strip():  # Path("") is ".": an empty name must not mean "here"
        raise FlexhrcError("DIR is empty: name the folder to write scenario.yaml into (. for here)")
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise FlexhrcError(f"{folder}: exists and is not a folder (DIR must be a folder)")
    target = folder / STARTER_NAME
    if target.exists() and not force:
        raise FlexhrcError(f"{target}: already exists (use --force to overwrite it)")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise FlexhrcError(f"{folder}: cannot create the folder ({exc.strerror})") from None
    atomic_write_text(target, STARTER)
    return target
