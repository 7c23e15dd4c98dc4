"""`python -m app` does what the `avhear` console script does."""
from __future__ import annotations

import sys

from app.cli import main

sys.exit(main())
