"""`python -m assembly.cli ...`: the same as `fvtree ...`."""

import sys

from assembly.cli import main

sys.exit(main())
