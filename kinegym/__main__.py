"""``python -m kinegym ...``: the same as the ``kinegym`` command (for instance in a tuning
worker started with ``sys.executable``)."""

import sys

from kinegym.cli import main

if __name__ == "__main__":
    sys.exit(main())
