"""Rigid-body mass properties: the one inertia record every engine reads.

A body's mass properties are stated in the body's own frame (see
``docs/conventions.md``, "Body frames"): the centre of mass ``com`` is a point
of that frame and ``inertia`` is the inertia tensor about the centre of mass,
in that frame's axes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dualmech.core.dual import scalar_type


@dataclass(frozen=True)
class BodyInertia:
    """Mass, centre of mass and central inertia of one rigid body.

    Attributes
    ----------
    mass : float
        Mass, in the case's mass unit (> 0).
    com : numpy.ndarray, shape (3,)
        Centre of mass in the body frame.
    inertia : numpy.ndarray, shape (3, 3)
        Symmetric, positive semi-definite inertia tensor about the centre of
        mass, in body-frame axes.
    """

    mass: float
    com: np.ndarray
    inertia: np.ndarray

    def __post_init__(self) -> None:
        com = np.asarray(self.com, dtype=scalar_type(self.com)).reshape(3)
        inertia = np.asarray(self.inertia, dtype=scalar_type(self.inertia)).reshape(3, 3)
        object.__setattr__(self, "com", com)
        object.__setattr__(self, "inertia", inertia)
        if not (np.isfinite(self.mass) and np.real(self.mass) > 0):  # real part: a complex step (dual.py)
            raise ValueError(f"mass: expected a finite positive number, got {self.mass!r}")
        # every check relative to the tensor's own size: no absolute floor, so no unit decides a verdict
        if not np.allclose(inertia, inertia.T, rtol=0, atol=1e-12 * np.abs(inertia).max()):
            raise ValueError(f"inertia: expected a symmetric 3x3 tensor, got {inertia.tolist()}")
        eig = np.linalg.eigvalsh(inertia)
        if eig.min() < -1e-12 * max(eig.max(), 0.0):
            raise ValueError(f"inertia: expected positive semi-definite, got eigenvalues {eig.tolist()}")
        a, b, c = np.sort(eig)
        if c > a + b + 1e-9 * c:
            raise ValueError(f"inertia: principal moments {eig.tolist()} violate the triangle inequality")


def solid_cylinder_x(mass: float, length: float, radius: float) -> np.ndarray:
    """Central inertia of a uniform solid cylinder whose axis is the body x axis.

    .. math:: I_{xx} = m r^2/2, \\quad I_{yy} = I_{zz} = m (r^2/4 + L^2/12)

    (The thesis, section 3.1, gives the radii of gyration about the distal
    end, :math:`K_y^2 = r^2/4 + a^2/3`; the parallel-axis theorem links the two.)
    """
    axial = 0.5 * mass * radius**2
    transverse = mass * (radius**2 / 4.0 + length**2 / 12.0)
    return np.diag([axial, transverse, transverse])


def solid_cube(mass: float, side: float) -> np.ndarray:
    """Central inertia of a uniform solid cube, :math:`m s^2/6` on the diagonal (thesis 3.1)."""
    return np.eye(3) * mass * side**2 / 6.0


@dataclass(frozen=True)
class MassArrays:
    """Batched twin of :class:`BodyInertia`: one body's mass properties per position.

    ``mass`` ``(n,)``, ``com`` ``(n, 3)`` (body frame), ``inertia`` ``(n, 3, 3)`` (about the
    centre of mass, body axes).  Lets positions of different cases share one batch.
    """

    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray

    @staticmethod
    def repeat(bodies: list[BodyInertia], counts: list[int]) -> "MassArrays":
        """Body ``bodies[i]`` repeated ``counts[i]`` times, concatenated."""
        return MassArrays(
            np.repeat([b.mass for b in bodies], counts),
            np.repeat([b.com for b in bodies], counts, axis=0),
            np.repeat([b.inertia for b in bodies], counts, axis=0),
        )

    def take(self, index: np.ndarray | slice) -> "MassArrays":
        return MassArrays(self.mass[index], self.com[index], self.inertia[index])
