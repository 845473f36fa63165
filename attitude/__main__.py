"""``python -m attitude``: the ``attitude`` command (see :mod:`attitude.cli`)."""

import sys

from attitude.cli import main

if __name__ == "__main__":
    sys.exit(main())
