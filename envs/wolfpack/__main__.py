"""``python -m wolfpack ...`` is the ``wolfpack`` command line (``wolfpack --help``)."""

from wolfpack.cli import main

if __name__ == "__main__":
    main()
