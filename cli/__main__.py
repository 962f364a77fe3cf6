"""``python -m dualmech.cli``: the same as the ``dualmech`` command."""

from dualmech.cli import main

main()
