"""Judges 2 and 3 of the slider crank, MuJoCo, written by hand: the rigid judge (:mod:`.closure`: the
compiled MJCF and its loop closure; :mod:`.dynamics`: rates, efforts, joint wrenches; :mod:`.engine`: a case
solved position by position) and the simulation (:mod:`.sim_plan`: rows, time grid, servo settings;
:mod:`.sim`: the servos, the soft loop, the table).  The package imports none of them."""
