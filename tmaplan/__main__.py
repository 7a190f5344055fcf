"""``python -m tmaplan``: the ``tmaplan`` command (as ``python -m tmaplan.cli``)."""

import sys

from tmaplan.cli import main

sys.exit(main())
