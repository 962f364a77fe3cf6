"""The linkages other than the slider crank (RSSR, RCCC; ``models/linkages/``) judged by Pinocchio and MuJoCo.

* :mod:`.engines` -- the registry: :func:`solve_linkage` ``(source, engine)`` with ``engine`` one of
  ``dualmech``, ``pinocchio``, ``mujoco``, ``mujoco-sim`` (the RSSR's simulation);
* the judges: :mod:`.pinocchio_rssr`, :mod:`.pinocchio_rccc`, :mod:`.mujoco_rssr`, :mod:`.mujoco_rccc`
  (rigid), :mod:`.mujoco_rssr_sim` (simulated), what they share (:mod:`.judges`) and their MJCF
  (:mod:`.mjcf_rssr`);
* the gate of ``dualmech validate rssr | rccc | linkages``: the linkage matrix (:mod:`.matrix`), the
  comparison (:mod:`.gate`) and its report (:mod:`.report`).
"""

from __future__ import annotations

from dualmech.validation.linkages.engines import ENGINES, solve_linkage

__all__ = ["ENGINES", "solve_linkage"]
