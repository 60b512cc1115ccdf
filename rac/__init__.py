"""racc, the robot architecture compiler: declarative models for diagnosis and repair."""

import sys

from rac.moved import MovedFinder

__version__ = "0.1.0"

# Module paths that moved but that files racc wrote earlier still import (rac.moved).
if not any(isinstance(f, MovedFinder) for f in sys.meta_path):
    sys.meta_path.append(MovedFinder())
