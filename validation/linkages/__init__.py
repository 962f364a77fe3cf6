"""The linkages other than the slider crank (RSSR, RCCC; ``models/linkages/``) judged by Pinocchio and MuJoCo.

* the simulated judges: :mod:`.mujoco_rssr_sim`, :mod:`.mujoco_rccc_sim`, started by the rigid MuJoCo
  answer of their own models (:mod:`.mujoco_rssr`, :mod:`.mujoco_rccc`, driven by :mod:`.judges`), their
  MJCF (:mod:`.mjcf_rssr`, :mod:`.mjcf_rccc`); the rigid judges are the generated judges of each case's
  joint table (:mod:`dualmech.validation.judges.presets`);
* the gate of ``dualmech validate rssr | rccc | linkages``: the linkage matrix (:mod:`.matrix`), the
  comparison (:mod:`.gate`) and its report (:mod:`.report`).

Their engines are registered beside the slider crank's, in the one registry
(:data:`dualmech.validation.engines.ENGINES`; :func:`~dualmech.validation.engines.solve_linkage`).
"""
