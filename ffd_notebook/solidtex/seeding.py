"""Random-number arguments: ``rng`` is an int or a :class:`numpy.random.Generator`, as in NumPy.

Most functions just build ``np.random.default_rng(rng)`` (an int gives the same numbers as the
old ``seed=``; a Generator is used as it is). A few need one integer root seed instead, because
they hash it (a Generator's state cannot be hashed reproducibly): :func:`integer_seed`.
"""

from __future__ import annotations

import operator

import numpy as np

__all__ = ["RNGLike", "integer_seed", "splitmix64"]

RNGLike = int | np.random.Generator


def integer_seed(rng: RNGLike) -> int:
    """An integer root seed: ``rng`` itself if it is an int, else one 63-bit draw from the Generator.

    Examples
    --------
    >>> integer_seed(7)
    7
    >>> a, b = integer_seed(np.random.default_rng(1)), integer_seed(np.random.default_rng(1))
    >>> a == b, 0 <= a < 2**63
    (True, True)
    """
    if isinstance(rng, np.random.Generator):
        return int(rng.integers(2**63))
    return operator.index(rng)


def splitmix64(x: np.ndarray) -> np.ndarray:
    """Steele, Lea and Flood's SplitMix64 finaliser: a bijective, well-mixed hash of 64-bit words.

    What the lazy textures draw their random numbers from: a hash of the seed and a position gives
    the same numbers wherever and whenever it is computed, on all positions at once.

    Examples
    --------
    >>> hex(int(splitmix64(np.array([0], np.uint64))[0]))
    '0xe220a8397b1dcdaf'
    """
    with np.errstate(over="ignore"):  # arithmetic modulo 2**64 is the point
        z = x + np.uint64(0x9E3779B97F4A7C15)
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        return z ^ (z >> np.uint64(31))
