"""`python -m dcmppi.cli [command] [options]`: the same as `dcmppi [command] [options]`."""

import sys

from dcmppi.cli import main

sys.exit(main())
