"""Per-sample random generators spawned from one root seed (NumPy ``SeedSequence``)."""

from __future__ import annotations

import numpy as np

__all__ = ["sample_rng"]


def sample_rng(seed: int, index: int) -> np.random.Generator:
    """The generator of sample ``index`` of a run with root ``seed``.

    ``SeedSequence(seed, spawn_key=(index,))`` is the ``index``-th child of
    ``SeedSequence(seed).spawn(...)``: what sample ``index`` is depends neither on how many
    samples there are nor on which worker makes it, or when.

    Parameters
    ----------
    seed : int
        The run's root seed.
    index : int
        The sample's id.

    Returns
    -------
    numpy.random.Generator
        A generator used only for that sample.

    Examples
    --------
    >>> a = sample_rng(7, 3).random()
    >>> b = np.random.default_rng(np.random.SeedSequence(7).spawn(5)[3]).random()
    >>> a == b
    True
    """
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(index,)))
