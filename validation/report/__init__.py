"""The report of a validation run: a self-contained HTML page, a Markdown summary and ``summary.json``.

Sections return data (:mod:`.sections`), figures are planned (:mod:`.figures`) and drawn as PNG bytes
(:mod:`.plots`, on the matplotlib figures of :mod:`.canvas`), and :func:`.render.write_report` renders
them with the Jinja2 templates in ``validation/templates/``, for a run of any kinds (the sections of the
kinds other than the slider crank: :mod:`.tables`).

The package imports none of them: each is imported from its own module, so that no module of the package
depends on the package itself (no import cycle).
"""
