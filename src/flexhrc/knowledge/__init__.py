"""Knowledge base: typed objects, poses, ground facts, closed world, consistency (paper 000, V)."""
