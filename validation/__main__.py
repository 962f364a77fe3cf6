"""``python -m dualmech.validation``: the same as the ``dualmech`` command."""

from dualmech.validation.cli import main

main()
