"""Judges generated from a loop table (:class:`~dualmech.models.loop.description.LoopMechanism`), one
package per outside engine: each builds its own model from the table, never from another judge's file nor
from the in-house engine's answers (issue 32, point 4; ``docs/conventions.md``, "Loop tables")."""
