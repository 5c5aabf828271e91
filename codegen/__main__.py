"""``python -m codegen``: the same as ``latdyn-codegen`` (codegen/cli.py)."""
import sys

from .cli import main

sys.exit(main())
