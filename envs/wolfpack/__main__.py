"""``python -m wolfpack ...`` is the ``wolfpack`` command line (``wolfpack --help``)."""

import sys

try:
    from wolfpack.cli import main
except KeyboardInterrupt:  # Ctrl-C while the command line is still loading
    sys.stderr.write("wolfpack: interrupted\n")
    sys.exit(130)

if __name__ == "__main__":
    main()
