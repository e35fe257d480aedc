"""``python -m citygen``: the same as the ``citygen`` command."""

from citygen.cli import main

main()
