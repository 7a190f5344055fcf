"""``python -m tmaplan.cli``."""

import sys

from tmaplan.cli import main

if __name__ == "__main__":  # importing it (the API reference) does not run the CLI
    sys.exit(main())
