"""Random-number arguments: ``rng`` is an int or a :class:`numpy.random.Generator`, as in NumPy.

Most functions just build ``np.random.default_rng(rng)`` (an int gives the same numbers as the
old ``seed=``; a Generator is used as it is). A few need one integer root seed instead, because
they hash it (a Generator's state cannot be hashed reproducibly): :func:`integer_seed`.
"""

from __future__ import annotations

import operator

import numpy as np

__all__ = ["RNGLike", "integer_seed"]

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
