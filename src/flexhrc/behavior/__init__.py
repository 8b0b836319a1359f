"""Activation-spreading behaviour network with THEN/AND/OR goal nodes (paper 002)."""
