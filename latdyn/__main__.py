"""``python -m latdyn``: the same as the ``latdyn`` command."""
import sys

from latdyn.cli import main

sys.exit(main())
