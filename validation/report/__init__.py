"""The report of a validation run: a self-contained HTML page, a Markdown summary and ``summary.json``.

Sections return data (:mod:`.sections`), figures are planned (:mod:`.figures`) and drawn as PNG bytes
(:mod:`.plots`, on the matplotlib figures of :mod:`.canvas`), and :func:`write_report` renders them with
the Jinja2 templates in ``validation/templates/`` (:mod:`.render`).
"""

from dualmech.validation.report.canvas import fig_to_png
from dualmech.validation.report.plots import Figure
from dualmech.validation.report.render import ReportError, ReportFiles, environment, write_report
from dualmech.validation.report.sections import summary_rows

__all__ = [
    "Figure",
    "ReportError",
    "ReportFiles",
    "environment",
    "fig_to_png",
    "summary_rows",
    "write_report",
]
