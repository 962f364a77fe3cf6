"""The linkages other than the slider crank (RSSR, RCCC; ``models/linkages/``) judged by Pinocchio and MuJoCo.

* their judges are the judges generated from each case's joint table (rigid and simulated:
  :mod:`dualmech.validation.judges.presets`);
* the gate of ``dualmech validate rssr | rccc | linkages``: the linkage matrix (:mod:`.matrix`), the
  comparison (:mod:`.gate`) and its report (:mod:`.report`).

Their engines are registered beside the slider crank's, in the one registry
(:data:`dualmech.validation.engines.ENGINES`; :func:`~dualmech.validation.engines.solve_linkage`).
"""
