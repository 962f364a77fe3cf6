"""The linkages other than the slider crank (RSSR, RCCC; ``models/linkages/``) judged by Pinocchio and MuJoCo.

* the judges: :mod:`.pinocchio_rssr`, :mod:`.pinocchio_rccc`, :mod:`.mujoco_rssr`, :mod:`.mujoco_rccc`
  (rigid), :mod:`.mujoco_rssr_sim` (simulated), what they share (:mod:`.judges`) and their MJCF
  (:mod:`.mjcf_rssr`);
* the gate of ``dualmech validate rssr | rccc | linkages``: the linkage matrix (:mod:`.matrix`), the
  comparison (:mod:`.gate`) and its report (:mod:`.report`).

Their engines are registered beside the slider crank's, in the one registry
(:data:`dualmech.validation.engines.ENGINES`; :func:`~dualmech.validation.engines.solve_linkage`).
"""
