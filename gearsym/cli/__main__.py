"""``python -m gearsym.cli``: the same as the ``gearsym`` console script."""

import sys

from . import main

sys.exit(main())
