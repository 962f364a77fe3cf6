"""Any single closed loop as a table of joints (``docs/conventions.md``, "Loop tables").

:class:`~dualmech.models.loop.description.LoopMechanism` is the description (joints, drive, bodies, loads),
:func:`~dualmech.models.loop.table_format.loop_from_dict` reads it from a file's tables,
:func:`~dualmech.models.loop.mobility.check_mobility` checks it moves with its driven coordinates,
:func:`~dualmech.models.loop.engine.analyze_loop` solves it, and :mod:`~dualmech.models.loop.presets` turns
the slider crank, the RSSR and the RCCC into such tables.
"""
