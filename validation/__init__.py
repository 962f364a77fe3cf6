"""Cross-validation: the judges' drivers, the matrix, comparison, baseline, JUnit and report.

Importing it imports no engine.  Its user-facing names (:func:`~dualmech.validation.api.solve`,
:func:`~dualmech.validation.api.validate`, :func:`~dualmech.validation.api.tolerance_study`, ...) are
re-exported by the package face, :mod:`dualmech`.
"""
