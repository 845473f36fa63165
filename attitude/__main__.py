"""``python -m attitude``: the ``attitude`` command (see :mod:`attitude.app.cli`)."""

import sys

from attitude.app.cli import main

if __name__ == "__main__":
    sys.exit(main())
