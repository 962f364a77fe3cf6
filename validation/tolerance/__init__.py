"""A tolerance study run and judged: the Monte Carlo chunks on the executors, sensitivities and statistics
(:mod:`.study`; the study's parts are :mod:`dualmech.models.tolerance`), spot checks of sampled designs by
the judges (:mod:`.spot_checks`), its summary and report (:mod:`.report`)."""
