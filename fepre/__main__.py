"""``python -m fepre`` runs the ``fepre`` command."""

import sys

from .cli import main

sys.exit(main())
