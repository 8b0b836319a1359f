"""Action level: robot models, task-priority control, in-the-loop simulator (paper 000, III)."""
