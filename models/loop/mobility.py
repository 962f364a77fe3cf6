"""Mobility of a single loop: Kutzbach-Grübler with the idle spins of S-S links.

A single closed loop of joints with :math:`f_i` freedoms moves with

.. math:: M = \\sum_i f_i - 6 - n_{idle}

degrees of freedom, where :math:`n_{idle}` counts the idle freedoms: a link between two spherical joints
can spin about the line of their centres without moving anything else.  That spin is fixed by the zero-spin
gauge of :class:`dualmech.core.loop.Loop` (``docs/conventions.md``, "Rod spin"), so it is neither a degree
of freedom to drive nor an unknown of the reactions.  A table is accepted when :math:`M` equals the number of
prescribed coordinates: 1, or 2 for a C joint driven by its angle (its slide follows the axial law).
Special geometry (parallel or intersecting axes that make a loop move against the count, such as the planar
four-bar's :math:`M = -2`) is not solved: such a loop's reactions are statically indeterminate; its error
says so (:func:`special_geometry`).
"""

from __future__ import annotations

import numpy as np

from dualmech.models.loop.description import Joint, LoopMechanism


def idle_spins(joints: tuple[Joint, ...]) -> tuple[int, ...]:
    """Indices ``i`` (0-based) of the moving links carried by a spherical joint ``i`` whose next joint
    ``i + 1`` is spherical too: each spins idly about the line of the two centres."""
    n = len(joints)
    return tuple(i for i in range(n - 1) if joints[i].type == "S" and joints[i + 1].type == "S")


def mobility(joints: tuple[Joint, ...]) -> int:
    """Kutzbach-Grübler mobility of the loop, :math:`\\sum f_i - 6 - n_{idle}` (module docstring)."""
    return sum(j.freedoms for j in joints) - 6 - len(idle_spins(joints))


def check_idle_links(mechanism: LoopMechanism) -> None:
    """Raise a one-line :class:`ValueError` unless every idly spinning link (:func:`idle_spins`) has its mass
    axisymmetric about its x axis, the line of its two ball centres: ``com = [x, 0, 0]`` and inertia
    ``diag(I_a, I_t, I_t)``, to 1e-12 of its size.  Otherwise the spin would be a real degree of freedom and
    the zero-spin gauge would not be harmless (``docs/conventions.md``, "Rod spin")."""
    for k in idle_spins(mechanism.joints):
        body = mechanism.bodies[k]
        i = body.inertia
        size = max(np.abs(i).max(), 1e-300)
        off = max(abs(i[0, 1]), abs(i[0, 2]), abs(i[1, 2]), abs(i[1, 1] - i[2, 2]))
        length = max(abs(body.com[0]), abs(mechanism.joints[k].a))
        if off > 1e-12 * size or max(abs(body.com[1]), abs(body.com[2])) > 1e-12 * length:
            raise ValueError(f"body[{k + 1}]: link {k + 1} spins idly between two S joints, so its mass must "
                             "be axisymmetric about its x axis (com [x, 0, 0], inertia diag(Ia, It, It)); "
                             f"got com {body.com.tolist()}, inertia {i.tolist()}")


def check_mobility(mechanism: LoopMechanism) -> None:
    """Raise a one-line :class:`ValueError` unless the loop's mobility equals its prescribed coordinates (and
    its idle links are axisymmetric: :func:`check_idle_links`).

    The message names the count and why, e.g. ``joint: mobility 2 (freedoms 9 - 6 - 1), 1 idle spin of link
    2 (S-S): a single loop needs 1 (one driven coordinate); remove 1 freedom``.
    """
    joints = mechanism.joints
    m = mobility(joints)
    need = len(mechanism.prescribed)
    if m == need:
        check_idle_links(mechanism)
        return
    idle = idle_spins(joints)
    total = sum(j.freedoms for j in joints)
    why = f"mobility {m} (freedoms {total} - 6"
    if idle:
        links = ", ".join(str(i + 1) for i in idle)
        why += f" - {len(idle)}), {len(idle)} idle spin{'s' if len(idle) > 1 else ''} of link {links} (S-S)"
    else:
        why += ")"
    what = "a C joint driven by its angle with its axial law" if need == 2 else "one driven coordinate"
    change = abs(need - m)
    special = special_geometry(joints)
    hint = (f"; a {special} {len(joints)}R loop moves, but its reactions are statically indeterminate: make "
            "it spatial, e.g. an RSSR") if special and m < need else ""
    raise ValueError(f"joint: {why}: a single loop needs {need} ({what}); "
                     f"{'add' if m < need else 'remove'} {change} freedom{'s' if change > 1 else ''}{hint}")


def special_geometry(joints: tuple[Joint, ...]) -> str | None:
    """``"planar"`` for a loop of R joints whose axes are all parallel (every twist 0 or 180 deg),
    ``"spherical"`` for one whose axes all meet in a point (every length and offset 0), else ``None``: the
    overconstrained loops (:math:`M = -2` by the count for four joints) that move all the same."""
    if not joints or any(j.type != "R" for j in joints):
        return None
    if all(abs(np.sin(j.alpha)) < 1e-12 for j in joints):
        return "planar"
    if all(j.a == 0.0 and j.s == 0.0 for j in joints):
        return "spherical"
    return None
