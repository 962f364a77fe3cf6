"""The thesis's position analysis as printed, transcribed symbol by symbol (Rahman 1991, section 2).

Matrices (1)-(4), the derivatives of section 2.5 and the operators (2a)-(4a), (8)-(10), dual-matrix
algebra, the loop product (18) and its residual (5), and the Newton-Raphson system (24)-(25) with the
iteration (23a).  ``docs/errata.md`` (E1-E3, E13) says where they are wrong.  Nothing here imports the
in-house solver.
"""

from __future__ import annotations

import numpy as np

c, s = np.cos, np.sin

# ============================================================================ printed matrices (1)-(4)


def m1(th1: float, s1: float, a1: float) -> tuple[np.ndarray, np.ndarray]:
    """Eq. (1): primary and dual part of 1_2M."""
    p = np.array([[c(th1), -s(th1), 0], [s(th1), c(th1), 0], [0, 0, 1]])
    d = np.array(
        [[-s1 * s(th1), -s1 * c(th1), a1 * s(th1)], [s1 * c(th1), -s1 * s(th1), -a1 * c(th1)], [0, a1, 0]]
    )
    return p, d


def l2(th2: float, et2: float, a2: float) -> tuple[np.ndarray, np.ndarray]:
    """Eq. (2)."""
    p = np.array([[c(th2) * c(et2), -s(th2), c(th2) * s(et2)], [s(th2) * c(et2), c(th2), s(th2) * s(et2)],
                  [-s(et2), 0, c(et2)]])
    d = np.array(
        [[0, a2 * c(th2) * s(et2), a2 * s(th2)], [0, a2 * s(th2) * s(et2), -a2 * c(th2)], [0, a2 * c(et2), 0]]
    )
    return p, d


def l3(th3: float, et3: float) -> tuple[np.ndarray, np.ndarray]:
    """Eq. (3) (no dual part: a3 = 0)."""
    p = np.array([[c(th3) * c(et3), c(th3) * s(et3), s(th3)], [s(th3) * c(et3), s(th3) * s(et3), -c(th3)],
                  [-s(et3), c(et3), 0]])
    return p, np.zeros((3, 3))


def m4(s4: float, al4: float, a4: float) -> tuple[np.ndarray, np.ndarray]:
    """Eq. (4)."""
    p = np.array([[1, 0, 0], [0, c(al4), -s(al4)], [0, s(al4), c(al4)]])
    d = np.array(
        [[0, -s4 * c(al4), s4 * s(al4)], [s4, -a4 * s(al4), -a4 * c(al4)], [0, a4 * c(al4), -a4 * s(al4)]]
    )
    return p, d


def dl2_dth2(th2, et2, a2):
    """Printed derivative of (2) with respect to theta2 (section 2.5)."""
    p = np.array(
        [
            [-s(th2) * c(et2), -c(th2), -s(th2) * s(et2)],
            [c(th2) * c(et2), -s(th2), c(th2) * s(et2)],
            [0, 0, 0],
        ]
    )
    d = np.array([[0, -a2 * s(th2) * s(et2), a2 * c(th2)], [0, a2 * c(th2) * s(et2), a2 * s(th2)], [0, 0, 0]])
    return p, d


def dl2_det2(th2, et2, a2):
    p = np.array(
        [
            [-c(th2) * s(et2), 0, c(th2) * c(et2)],
            [-s(th2) * s(et2), 0, s(th2) * c(et2)],
            [-c(et2), 0, -s(et2)],
        ]
    )
    d = np.array([[0, a2 * c(th2) * c(et2), 0], [0, a2 * s(th2) * c(et2), 0], [0, -a2 * s(et2), 0]])
    return p, d


def dl3_dth3(th3, et3):
    return np.array([[-s(th3) * c(et3), -s(th3) * s(et3), c(th3)], [c(th3) * c(et3), c(th3) * s(et3), s(th3)],
                     [0, 0, 0]]), np.zeros((3, 3))


def dl3_det3(th3, et3):
    return np.array([[-c(th3) * s(et3), c(th3) * c(et3), 0], [-s(th3) * s(et3), s(th3) * c(et3), 0],
                     [-c(et3), -s(et3), 0]]), np.zeros((3, 3))


def dm4_ds4(al4):
    return np.zeros((3, 3)), np.array([[0, -c(al4), s(al4)], [1, 0, 0], [0, 0, 0]])


def q_theta():
    """Eqs. (2a), (3a), (8)."""
    return np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 0]]), np.zeros((3, 3))


def q_eta(th):
    """Eqs. (2b), (3b), (9)."""
    return np.array([[0, 0, c(th)], [0, 0, s(th)], [-c(th), -s(th), 0]]), np.zeros((3, 3))


def q_s():
    """Eqs. (4a), (10): epsilon times the Q_theta pattern."""
    return np.zeros((3, 3)), np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 0]])


def dmul(a, b):
    """Product of dual matrices given as (primary, dual)."""
    return a[0] @ b[0], a[0] @ b[1] + a[1] @ b[0]


def dtr(a):
    return a[0].T, a[1].T


def dvec(a, v):
    """Dual matrix times dual vector (primary, dual)."""
    return a[0] @ v[0], a[0] @ v[1] + a[1] @ v[0]


def frame_origin(a) -> np.ndarray:
    """Origin ``p`` of the later frame in the earlier one, from :math:`\\hat M = R + \\varepsilon[p]_\\times
    R`."""
    m = a[1] @ a[0].T
    return 0.5 * np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])


def loop_product(x, th1, s1, a1, a2, a4, al4):
    """B of eq. (18) for the thesis's unknowns x = (theta2, eta2, theta3, eta3, S4)."""
    th2, et2, th3, et3, s4 = x
    return dmul(dmul(dmul(m1(th1, s1, a1), l2(th2, et2, a2)), l3(th3, et3)), m4(s4, al4, a4))


def closure_residual(x, th1, s1, a1, a2, a4, al4) -> np.ndarray:
    """All 18 entries of :math:`\\hat B - \\hat I` (dual part over a2): eq. (5) as a residual vector."""
    b = loop_product(x, th1, s1, a1, a2, a4, al4)
    return np.concatenate([(b[0] - np.eye(3)).ravel(), b[1].ravel() / a2])


def newton_system(x, th1, s1, a1, a2, a4, al4, diagonal: bool = True):
    """A of eq. (24) and V of eq. (25) (``diagonal=False``: V of the unmodified eqs. (20)-(21))."""
    th2, et2, th3, et3, s4 = x
    p1 = m1(th1, s1, a1)
    p2 = dmul(p1, l2(th2, et2, a2))
    p3 = dmul(p2, l3(th3, et3))
    hs = [dmul(dmul(p1, q_theta()), dtr(p1)), dmul(dmul(p1, q_eta(th2)), dtr(p1)),
          dmul(dmul(p2, q_theta()), dtr(p2)), dmul(dmul(p2, q_eta(th3)), dtr(p2)),
          dmul(dmul(p3, q_s()), dtr(p3))]
    idx = [(0, 1), (0, 2), (1, 2)]
    a = np.array([[h[part][i, j] for h in hs] for part in (0, 1) for (i, j) in idx])
    bp, bd = dmul(p3, m4(s4, al4, a4))
    if diagonal:
        vp = [
            bp[1, 0] + bp[0, 0] + bp[1, 1] - 2,
            bp[2, 0] + bp[0, 0] + bp[2, 2] - 2,
            bp[2, 1] + bp[1, 1] + bp[2, 2] - 2,
        ]
    else:
        vp = [bp[1, 0], bp[2, 0], bp[2, 1]]
    return a, np.array(vp + [bd[1, 0], bd[2, 0], bd[2, 1]])


def thesis_newton(x, geom, iterations: int, diagonal: bool = True):
    """The printed iteration: Delta = (A^T A)^-1 A^T V (eq. 23a), x += Delta. Returns x and |B - I| per
    step."""
    history = []
    for _ in range(iterations):
        a, v = newton_system(x, *geom, diagonal=diagonal)
        x = x + np.linalg.solve(a.T @ a, a.T @ v)
        history.append(float(np.linalg.norm(closure_residual(x, *geom))))
    return x, np.array(history)
