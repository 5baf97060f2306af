"""``python -m avtrack``: the ``avtrack`` command line (:func:`avtrack.cli.main.main`)."""

import sys

from avtrack.cli.main import main

if __name__ == "__main__":
    sys.exit(main())
