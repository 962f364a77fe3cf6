"""The MJCF of the linkages.  RSSR: hinge, ball, hinge, and the loop closed by a connect at ball 3.

::

    world
     ├─ input_crank    at (0, 0, s1): hinge "joint1" about z
     │   └─ coupler    at (a1, 0, 0): ball "joint2";  site "coupler_end" at (a2, 0, 0)
     └─ output_crank   at Q4, axes G4 = Rx(-alpha4): hinge "joint4" about its z = k4;
                       site "output_pin" at (a3, 0, 0)

    equality: connect "joint3" site1="output_pin" site2="coupler_end"

Body frames are those of ``docs/conventions.md`` ("RSSR"), so the case's mass properties go in
unchanged (``fullinertia`` about the centre of mass, body axes).  ``qpos = (theta1,
quat_wxyz(coupler), phi4)``; ``qvel = (theta1_dot, omega(coupler, its axes), phi4_dot)``.  No
MuJoCo import here: the text is plain MJCF.
"""

from __future__ import annotations

import numpy as np

from dualmech.core.inertia import BodyInertia
from dualmech.models.linkages.rccc_case import RcccCase
from dualmech.models.linkages.rssr_case import RssrCase


def _vec(values: np.ndarray) -> str:
    return " ".join(repr(float(v)) for v in values)


def _inertial(body: BodyInertia) -> str:
    i = body.inertia
    full = (i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2], i[1, 2])
    return (f'<inertial pos="{_vec(body.com)}" mass="{float(body.mass)!r}" '
            f'fullinertia="{_vec(np.array(full))}"/>')


def _quat_wxyz(rot: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation about the x axis ``rot`` (the ground frame G4)."""
    half = 0.5 * np.arctan2(rot[2, 1], rot[1, 1])
    return np.array([np.cos(half), np.sin(half), 0.0, 0.0])


def rssr_mjcf(case: RssrCase, timestep: float = 1e-4, servo: tuple[float, float] | None = None) -> str:
    """The MJCF text of ``case`` (module docstring); ``timestep`` matters only to a simulation.

    With ``servo = (kp, kv)`` the model is written for simulation: an input-angle servo ``input_servo``
    (``<general>``, affine bias: force ``kp ctrl - kp theta1 - kv theta1_dot``), the connect as stiff as
    MuJoCo allows (time constant ``2 timestep``, damping ratio 2, impedance 0.9999), ``implicitfast``.
    """
    g, (crank, coupler, output) = case.geometry, case.bodies
    soft, actuator, integrator = "", "", ""
    if servo is not None:
        kp, kv = float(servo[0]), float(servo[1])
        soft = f' solref="{2 * timestep!r} 2.0" solimp="0.9999 0.9999 0.001 0.5 2"'
        actuator = (f'  <actuator>\n    <general name="input_servo" joint="joint1" gainprm="{kp!r}" '
                    f'biastype="affine" biasprm="0 {-kp!r} {-kv!r}"/>\n  </actuator>\n')
        integrator = ' integrator="implicitfast"'

    return f"""<mujoco model="rssr">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{timestep!r}" gravity="{_vec(case.gravity)}"{integrator}/>
  <worldbody>
    <body name="input_crank" pos="0 0 {g.s1!r}">
      <joint name="joint1" type="hinge" axis="0 0 1"/>
      {_inertial(crank)}
      <body name="coupler" pos="{g.a1!r} 0 0">
        <joint name="joint2" type="ball"/>
        {_inertial(coupler)}
        <site name="coupler_end" pos="{g.a2!r} 0 0"/>
      </body>
    </body>
    <body name="output_crank" pos="{_vec(g.foot)}" quat="{_vec(_quat_wxyz(g.ground_rotation()))}">
      <joint name="joint4" type="hinge" axis="0 0 1"/>
      {_inertial(output)}
      <site name="output_pin" pos="{g.a3!r} 0 0"/>
    </body>
  </worldbody>
  <equality>
    <connect name="joint3" site1="output_pin" site2="coupler_end"{soft}/>
  </equality>
{actuator}</mujoco>
"""


def _placed(body: BodyInertia, alpha: float, a: float) -> BodyInertia:
    """``body`` (given in its own frame) expressed in a frame it sits at ``X(-alpha - eps a)`` from."""
    c, s = np.cos(alpha), np.sin(alpha)
    rot = np.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]])
    return BodyInertia(body.mass, np.array([-a, 0.0, 0.0]) + rot @ body.com, rot @ body.inertia @ rot.T)


def _x_attributes(alpha: float, a: float) -> str:
    """``pos`` and ``quat`` of a frame at ``X(-alpha - eps a)`` from its parent."""
    return f'pos="{-a!r} 0 0" quat="{_vec(np.array([np.cos(alpha / 2), -np.sin(alpha / 2), 0.0, 0.0]))}"'


def rccc_mjcf(case: RcccCase, timestep: float = 1e-4) -> str:
    """The MJCF text of an RCCC case: the loop's table read backwards from the ground, each cylinder a
    hinge and a slide about the same z axis, the input link's frame a site (the cut at the input revolute:
    ``qpos = (-theta4, -s4, -theta3, -s3, -theta2, -s2)``; ``docs/conventions.md``, "RCCC")."""
    g = case.geometry
    names = ("output_link", "coupler", "input_link")
    opened, closed = [], []
    for k, name in enumerate(names):
        row = 3 - k  # the table row whose X(...) this body's frame undoes
        body = _placed(case.bodies[2 - k], g.alpha[row - 1], g.a[row - 1])
        joint = 4 - k
        indent = "  " * (k + 2)
        opened.append(f'{indent}<body name="{name}" {_x_attributes(g.alpha[row], g.a[row])}>\n'
                      f'{indent}  <joint name="joint{joint}" type="hinge" axis="0 0 1"/>\n'
                      f'{indent}  <joint name="joint{joint}_slide" type="slide" axis="0 0 1"/>\n'
                      f'{indent}  {_inertial(body)}')
        closed.append(f"{indent}</body>")
    site = f'          <site name="input" {_x_attributes(g.alpha[0], g.a[0])}/>'
    tree = "\n".join(opened + [site] + closed[::-1])
    return f"""<mujoco model="rccc">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{timestep!r}" gravity="{_vec(case.gravity)}"/>
  <worldbody>
{tree}
  </worldbody>
</mujoco>
"""
