"""``python -m wolfpack.cli``: the ``wolfpack`` command."""

from wolfpack.cli.main import main

main()
