"""Perception level: human action recognition and scene perception (paper 000, III)."""
