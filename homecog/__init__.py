"""homecog: service cognition for home service robots.

The pipeline, one sub-package per stage::

    home (definition) -> environment -> learning (Sarsa, Q table) -> ...
"""

from __future__ import annotations

__version__ = "0.1.0"
