"""`python -m hapticd`: the command line (hapticd.cli)."""

import sys

from hapticd.cli import main

sys.exit(main())
