"""The result of a forward-dynamics run: the simulated motion, its energies and joint reactions.

:func:`dualmech.models.slider_crank.forward_dynamics.simulate` returns a :class:`Simulation`; its columns
(:data:`SIMULATION_COLUMNS`, ``docs/conventions.md``) go to CSV through the one writer of
dualmech's outputs, :func:`dualmech.core.table.write_csv`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dualmech.core.reactions import Reactions
from dualmech.core.table import REACTION_COLUMNS, write_csv
from dualmech.models.case import Case


@dataclass(frozen=True)
class Simulation:
    """A simulated motion at ``n`` output times; arrays ``(n,)`` unless stated.

    Attributes
    ----------
    t : time. ``psi``, ``psi_dot``, ``psi_ddot``: crank angle :math:`\\theta_1` (rad) and rates.
    s1, s4, s4_dot, s4_ddot : crank axial position and slider coordinate with rates (in-house).
    torque, slider_load : the applied motor torque :math:`\\tau^A` and slider load ``F``
        (without damping).
    kinetic, potential : :math:`T` and :math:`V = -\\sum m_b g\\cdot c_b` (in-house motion).
    work_drive, work_slider, dissipated : :math:`\\int\\tau^A\\dot\\psi\\,dt`,
        :math:`-\\int F\\dot S_4\\,dt`, :math:`\\int (c_1\\dot\\psi^2 + c_4\\dot S_4^2)dt`
        (integrated with the ODE).
    reactions : Reactions
        In-house joint reactions along the trajectory (world axes; ``slider_load``
        there includes the slider damper, ``drive_torque`` = ``j1_mz`` = motor torque
        + bearing damping :math:`- j_{1z} S_1'` of the axial constraint).
    transmission, status : in-house transmission index and status words.
    info : dict
        Integrator and coefficient-model facts (``method``, ``rtol``, ``atol``,
        ``nfev``, ``coefficients``, ``table_size``, ``interpolation_error``, ``message``).
    """

    case: Case
    t: np.ndarray
    psi: np.ndarray
    psi_dot: np.ndarray
    psi_ddot: np.ndarray
    s1: np.ndarray
    s4: np.ndarray
    s4_dot: np.ndarray
    s4_ddot: np.ndarray
    torque: np.ndarray
    slider_load: np.ndarray
    kinetic: np.ndarray
    potential: np.ndarray
    work_drive: np.ndarray
    work_slider: np.ndarray
    dissipated: np.ndarray
    reactions: Reactions
    transmission: np.ndarray
    status: np.ndarray
    info: dict

    def energy_residual(self) -> np.ndarray:
        """Work–energy balance :math:`\\Delta(T + V) - (W^A + W^S - D)`, ``(n,)`` (zero for an exact
        solution)."""
        e = self.kinetic + self.potential
        return (e - e[0]) - (self.work_drive + self.work_slider - self.dissipated)

    def columns(self) -> dict[str, np.ndarray]:
        """Output columns in CSV order (names in :data:`SIMULATION_COLUMNS`)."""
        return {
            "t": self.t, "theta1_deg": np.degrees(self.psi), "psi": self.psi, "psi_dot": self.psi_dot,
            "psi_ddot": self.psi_ddot, "S1": self.s1, "S4": self.s4, "S4_dot": self.s4_dot,
            "S4_ddot": self.s4_ddot, "torque_applied": self.torque, "slider_load_applied": self.slider_load,
            "kinetic_energy": self.kinetic, "potential_energy": self.potential, "work_drive": self.work_drive,
            "work_slider": self.work_slider, "dissipated": self.dissipated,
            **self.reactions.columns(), "transmission": self.transmission,
        }

    def to_csv(self, path: str | Path | None = None) -> str:
        """CSV text of :meth:`columns` plus ``status`` (full precision,
        :func:`~dualmech.core.table.write_csv`); written to ``path`` if given."""
        return write_csv(self.columns(), self.status, path)


#: Column order of :meth:`Simulation.columns` (then ``status``).
SIMULATION_COLUMNS: tuple[str, ...] = (
    "t", "theta1_deg", "psi", "psi_dot", "psi_ddot", "S1", "S4", "S4_dot", "S4_ddot", "torque_applied",
    "slider_load_applied", "kinetic_energy", "potential_energy", "work_drive", "work_slider", "dissipated",
) + REACTION_COLUMNS + ("transmission",)
