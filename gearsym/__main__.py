"""``python -m gearsym``: the same as the ``gearsym`` console script."""

import sys

from .cli import main

sys.exit(main())
