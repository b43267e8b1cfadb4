"""``python -m dressmeup`` runs the command line."""

import sys

from dressmeup.cli import main

sys.exit(main())
