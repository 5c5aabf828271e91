"""``python -m latdyn``: the same as the ``latdyn`` command."""
import sys

from .cli import main

sys.exit(main())
