"""``python -m tin_swarm_env ...`` runs the ``tin-swarm`` command line."""

import sys

from .apps.cli import main

sys.exit(main())
