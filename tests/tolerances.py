"""Tolerances of the in-house solver's own tests, each with its reason (judges: validation/tolerances.py)."""

#: S4 against the closed form, relative to a2: Newton stops at a closure residual of 1e-14 (x a2).
S4_VS_CLOSED_FORM = 1e-12
#: Rates against exact (dual-number + complex-step) derivatives, relative to the case's peak.
RATES_VS_EXACT = 1e-11
#: Identity tests of the dynamics (power, momentum balance), relative to the largest term.
BALANCE = 1e-10
#: A batched answer against the same answer computed one position at a time.
BATCH_VS_SINGLE = 1e-12
#: Finite-difference checks of screws and twists (central differences, step 1e-6: error ~1e-10).
FINITE_DIFFERENCE = 1e-7
#: Shared inputs (mass properties, crank motion) against the same formula evaluated by hand: round-off only
#: (measured <= 2e-16 relative).
COMMON_MODE_INPUT = 1e-13
