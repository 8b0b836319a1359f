"""Ready-made tasks: builders that return a :class:`~flexhrc.scenario.Scenario`, and the data
of the shipped scenario files (``data/NAME/NAME.yaml``).

* :func:`table_assembly` — the paper's table assembly in three segments (tabletop, legs,
  check; ``segments="legs"`` for the legs fix alone), any number of legs, any tabletop;
* :func:`parallel_assembly` — independent sockets on a bench for many arms and operators;
* :mod:`flexhrc.scenario.builtin.table_setting` — the behaviour-network tasks of paper 002
  (``flexhrc behave``; a task for the behaviour network, not for the Task Manager).
"""

from flexhrc.scenario.builtin.parallel import parallel_assembly
from flexhrc.scenario.builtin.table import SEGMENTS, ScenarioError, table_assembly

#: The builders by name (as the command line names them).
BUILDERS = {"table_assembly": table_assembly, "parallel_assembly": parallel_assembly}

__all__ = ["BUILDERS", "SEGMENTS", "ScenarioError", "parallel_assembly", "table_assembly"]
