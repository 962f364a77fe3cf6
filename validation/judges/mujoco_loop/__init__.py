"""MuJoCo as a rigid judge of any single loop table: :func:`~.mjcf.loop_mjcf` writes the MJCF,
:func:`~.engine.solve_loop` closes, differentiates and balances it position by position."""

from dualmech.validation.judges.mujoco_loop.engine import LoopTable, solve_loop
from dualmech.validation.judges.mujoco_loop.mjcf import loop_mjcf

__all__ = ["LoopTable", "loop_mjcf", "solve_loop"]
