"""The Pinocchio judge generated from any loop table: :func:`~.model.build_model` (the tree cut at the last
joint), :func:`~.continuation.close_loop` (its own closure), :mod:`~.dynamics` (rates, constrained inverse
dynamics) and :func:`~.engine.solve_loop` (the table of answers).  It never imports the in-house engine."""
