"""``python -m tmaplan.cli``."""

import sys

from tmaplan.cli import main

sys.exit(main())
