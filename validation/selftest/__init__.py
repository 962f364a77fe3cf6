"""``dualmech selftest``: the validation gate proves it can fail (mutation testing).

A catalogue (``validation/mutants.toml``) lists deliberate faults, each one small
source change -- ``old`` text replaced by ``new`` text in one file -- in the
in-house solver, in the inputs every engine shares, in each judge and in the
comparison itself.  For every fault this module

1. copies the source tree (``core/``, ``models/``, ``validation/``, ``tests/``,
   ``docs/``, ``reports/``, ``pyproject.toml``, ``README.md``) to a scratch
   directory and applies the fault there (the checkout is never touched);
2. runs **the gate** on the scratch copy in fresh Python processes that import
   the scratch copy, not the installed package (:data:`BOOT` removes the
   editable-install finder and checks every ``dualmech`` package's
   ``__file__``):

   a. the catalogue's validation matrix (``matrix``, a fast subset of the default
      one that still exercises gravity, crank acceleration and an axial S1 law),
      with ``dualmech validate --baseline`` semantics: it fails when any check
      fails or anything regressed against the baseline that the *unmutated*
      copy wrote in the same selftest run;
   b. only when (a) passes: the catalogue's fast test modules (``tests``),
      ``pytest -x -q`` with the Hypothesis profile ``selftest`` (the CI profile's
      examples, a failure reported as found, not shrunk);

   (for a fault in the comparison, b then a: it leaves every engine's numbers
   as they were, and its unit tests decide faster);

3. counts the fault **killed** when (a) or (b) fails (a crash or a non-zero exit
   is a failure, as it would be in CI), and records which part killed it.

The compiled kernel's numba cache is copied with the source: it is keyed on a
digest of the kernel's files, so a fault there recompiles the kernel and any
other fault reuses the unmutated copy's warm cache.

Before any fault, the gate runs on an unmutated copy and must pass: a gate that
fails without a fault proves nothing, so the selftest stops there.  A fault
whose ``old`` text does not occur exactly once in its file is *stale*: an
ERROR, never counted as killed.  A gate step that outlives ``timeout`` seconds
is stopped and the fault counted as killed by ``timeout`` (listed as such): the
CI job has no shorter limit, so a hang would fail CI too, later.

The score is ``killed / faults``; anything below 100 % exits 1.
"""

from dualmech.validation.selftest.catalogue import (
    CATALOGUE,
    CLASSES,
    Catalogue,
    Mutant,
    SelftestError,
    load_catalogue,
    parse_catalogue,
    stale_reason,
)
from dualmech.validation.selftest.gate import (
    BOOT,
    WRONG_IMPORT,
    GateRun,
    gate_main,
    run_gate,
)
from dualmech.validation.selftest.run import (
    Outcome,
    Report,
    format_report,
    run_selftest,
)
from dualmech.validation.selftest.scratch import PACKAGES, check_source, make_scratch, source_root

__all__ = [
    "BOOT", "CATALOGUE", "CLASSES", "WRONG_IMPORT", "Catalogue", "GateRun", "Mutant", "Outcome", "PACKAGES",
    "Report", "SelftestError", "check_source", "format_report", "gate_main", "load_catalogue", "make_scratch",
    "parse_catalogue", "run_gate", "run_selftest", "source_root", "stale_reason",
]
