"""dualmech's numpy-only floor: dual-number algebra, link-joint loop, closure, rates and the result table.

Importing it imports numpy only.  Its user-facing names (:class:`~dualmech.core.table.ResultTable`,
:class:`~dualmech.core.status.Status`) are re-exported by the package face, :mod:`dualmech`.
"""
