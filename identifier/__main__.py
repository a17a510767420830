"""``python -m identifier``: see :mod:`identifier.cli`."""

import sys

from identifier.cli import main

sys.exit(main())
