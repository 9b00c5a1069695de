"""`python -m dcmppi.bench.timing [options]`: the same as `dcmppi timing [options]`."""

import sys

from dcmppi.bench.timing import main

sys.exit(main())
