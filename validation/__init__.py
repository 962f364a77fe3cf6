"""Cross-validation: the judges' drivers, the matrix, comparison, baseline, JUnit and report.

Importing it imports no engine.  Its user-facing names (:func:`~dualmech.verbs.solve`,
:func:`~dualmech.verbs.validate`, :func:`~dualmech.verbs.tolerance_study`, ...) are
re-exported by the package face, :mod:`dualmech`.
"""
