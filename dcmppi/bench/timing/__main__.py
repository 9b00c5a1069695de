"""`python -m dcmppi.bench.timing [options]`: the same as `dcmppi timing [options]`."""

import sys

from .cli import main

sys.exit(main())
