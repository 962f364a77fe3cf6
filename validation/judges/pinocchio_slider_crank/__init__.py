"""Judge 1 of the slider crank, Pinocchio, written by hand: the model of a case (:mod:`.model`: the tree cut
at joint 3), closing the loop (:mod:`.closure`), rates and the closed loop's inverse dynamics
(:mod:`.dynamics`), and a case solved (:mod:`.engine`).  The package imports none of them."""
