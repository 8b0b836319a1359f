"""Readers and writers of AND/OR graph files: ANDOR text, YAML, DOT."""
