"""The mechanism and its inputs: case files, bodies, the in-house engine, forward dynamics, tolerances.

Importing it loads no judge (no Pinocchio, MuJoCo or matplotlib).  Its user-facing names
(:class:`~dualmech.models.case.Case`, :func:`~dualmech.models.case.load_case`, ...) are re-exported by the
package face, :mod:`dualmech`.
"""
