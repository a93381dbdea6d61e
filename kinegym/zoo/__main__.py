"""``python -m kinegym.zoo``: RL Zoo's train / enjoy / record_video with MaskablePPO (see :mod:`kinegym.zoo`)."""

import sys

from kinegym.zoo import main

if __name__ == "__main__":
    sys.exit(main())
