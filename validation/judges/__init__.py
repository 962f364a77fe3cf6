"""Judges generated from a loop table (``docs/conventions.md``, "Loop tables"): each builds its own model of
the table and solves it with its own engine, never from the in-house answers."""
