"""Python run in processes of their own, for what must be the same in every process."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterable


def outputs_by_hash_seed(code: str, seeds: Iterable[int]) -> set[str]:
    """What ``python -c code`` prints (stripped) under each hash seed: one element where the
    output never depends on the order of a set of strings."""
    return {
        subprocess.run(
            [sys.executable, "-c", code],
            env={**os.environ, "PYTHONHASHSEED": str(seed)},
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        for seed in seeds
    }
