"""The Exudyn judge generated from any loop table: absolute coordinates, hard constraints, reactions from the
Lagrange multipliers of Exudyn's dynamic runs with the drive prescribed.  :mod:`~.frames` and
:mod:`~.closure` (its own closure in joint coordinates), :mod:`~.law` (the drive law of a run),
:mod:`~.model` (the Exudyn system), :mod:`~.readout` (a state as a row), :mod:`~.engine` (the runs,
averaging and Richardson extrapolation), :mod:`~.table` (the shared table).  It never imports the in-house
engine."""
