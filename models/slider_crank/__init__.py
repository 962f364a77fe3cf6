"""The generalized slider crank, the thesis's mechanism: its link-joint table and batch of positions
(:mod:`.loop`), loop closure (:mod:`.closure`), the in-house analysis and its table (:mod:`.analysis`), the
same compiled (:mod:`.kernel`, with :mod:`.kernel_nb` and :mod:`.position_nb`: numba), sweeps on the kernel
(:mod:`.stroke`) and the thesis's verdicts (:mod:`.findings`), the dynamics coefficients
(:mod:`.dynamics_coefficients`), forward dynamics (:mod:`.forward_dynamics`) and force balancing
(:mod:`.balancing`).  The package imports none of them: each is imported from its own module.
"""
