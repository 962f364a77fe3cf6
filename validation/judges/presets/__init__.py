"""The generated judges on the RSSR and RCCC: each case's joint table solved by the judge of any loop table,
its columns read back as the mechanism's own table.

The case becomes its table (:func:`~dualmech.models.loop.presets.rssr_table`,
:func:`~dualmech.models.loop.presets.rccc_table`; ``docs/conventions.md``, "Loop tables") with every joint's
start a crude pose of the judge's own on the case's branch (:mod:`.starts`: the cut joint's angle at a grid
point of a scan next to the wanted root, the other joints aimed from it; the reach of the case's geometry),
so nothing of the in-house solver enters the judge.  The generated judge closes the loop from there by its
own continuation, restarted past gaps (:mod:`.run`, by the runs every engine of these kinds shares:
:mod:`dualmech.models.linkages.restarts`); its columns are read back as the mechanism's
(:mod:`dualmech.models.linkages.readback`, as the in-house engine's are).  :mod:`.engines` holds the
registered engines (Pinocchio, rigid MuJoCo, Exudyn, the MuJoCo simulation).
"""
