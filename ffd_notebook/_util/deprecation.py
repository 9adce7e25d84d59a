"""Old keyword names kept working for a while: the package spells ``rng`` (as NumPy does) and ``color``.

A renamed keyword is accepted under its old name with a :class:`DeprecationWarning`, so notebooks
written against the old name keep running while they say what to change.
"""

from __future__ import annotations

import warnings
from collections.abc import MutableMapping
from typing import Any

__all__ = ["renamed_keyword"]


def renamed_keyword(kwargs: MutableMapping[str, Any], old: str, new: str, value: Any, where: str) -> Any:
    """Value of keyword ``new``, taking (and removing) the deprecated ``old`` from ``kwargs``.

    Parameters
    ----------
    kwargs : dict
        The caller's ``**kwargs``; ``old`` is popped from it, so the rest can be passed on.
    old, new : str
        The deprecated and the current keyword.
    value
        What the caller got for ``new`` (its default when not given).
    where : str
        The function's name, for the messages.

    Examples
    --------
    >>> import warnings
    >>> renamed_keyword({}, "seed", "rng", 3, "f")
    3
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     renamed_keyword({"seed": 5}, "seed", "rng", None, "f")
    5
    >>> print(caught[0].message)
    f(seed=...) is deprecated: use rng=...
    """
    if old not in kwargs:
        return value
    old_value = kwargs.pop(old)
    warnings.warn(f"{where}({old}=...) is deprecated: use {new}=...", DeprecationWarning, stacklevel=3)
    return old_value
