"""One seed, split into named independent random streams (DESIGN: no shared global RNG).

Each stream is derived from the episode seed and the stream's name alone, so adding a stream or
drawing more from one never shifts the others: two policies run on one seed face the same zone
centers and the same attack draws for the same positions.
"""

from __future__ import annotations

import zlib

import numpy as np


def stream(seed: int, name: str) -> np.random.Generator:
    """The generator for stream ``name`` of episode ``seed``."""
    key = zlib.crc32(name.encode("utf-8"))
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence([int(seed), key])))
