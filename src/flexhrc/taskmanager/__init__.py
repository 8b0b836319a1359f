"""Task Manager: action schemas, Action-State table, decision tree, allocation (paper 000, V)."""
