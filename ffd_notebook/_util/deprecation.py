"""Old keyword names kept working for a while: the package spells ``rng`` (as NumPy does) and ``color``.

A renamed keyword is accepted under its old name with a :class:`DeprecationWarning`, so notebooks
written against the old name keep running while they say what to change.
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Callable, MutableMapping
from typing import Any

__all__ = ["REMOVED_IN", "renamed", "renamed_keyword", "warn_renamed"]


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


#: The release that removes the names deprecated in this one (they keep working, with a warning, until then).
REMOVED_IN = "0.3.0"


def warn_renamed(old: str, new: str, *, removed_in: str = REMOVED_IN, stacklevel: int = 3) -> None:
    """Warn that ``old`` is deprecated: a :class:`DeprecationWarning` naming ``new`` and the removal release.

    Parameters
    ----------
    old, new : str
        The deprecated name and the one to use.
    removed_in : str
        The version that removes ``old``.
    stacklevel : int
        As for :func:`warnings.warn`; the default points at the caller of the deprecated function.

    Examples
    --------
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     warn_renamed("save_ffd", "save_deformation")
    >>> print(caught[0].message)
    save_ffd is deprecated and will be removed in ffd_notebook 0.3.0: use save_deformation
    """
    warnings.warn(f"{old} is deprecated and will be removed in ffd_notebook {removed_in}: use {new}",
                  DeprecationWarning, stacklevel=stacklevel)  # fmt: skip


def renamed(new: Callable[..., Any], old: str, *, removed_in: str = REMOVED_IN) -> Callable[..., Any]:
    """A deprecated alias ``old`` of the function or method ``new``: it warns, then calls ``new``.

    The :class:`DeprecationWarning` names the new name and the release that removes the old one.

    Parameters
    ----------
    new : callable
        The function or method under its new name.
    old : str
        The old name, kept working for one release.
    removed_in : str
        The version that removes ``old``.

    Returns
    -------
    callable
        The alias, to assign to ``old`` (in a class body for a method).

    Examples
    --------
    >>> import warnings
    >>> class Thing:
    ...     def load_deformation(self, path):
    ...         return f"loaded {path}"
    ...     load_ffd = renamed(load_deformation, "load_ffd")
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     Thing().load_ffd("a.ffd")
    'loaded a.ffd'
    >>> print(caught[0].message)
    load_ffd is deprecated and will be removed in ffd_notebook 0.3.0: use load_deformation
    """

    @functools.wraps(new)
    def alias(*args: Any, **kwargs: Any) -> Any:
        warn_renamed(old, new.__name__, removed_in=removed_in)
        return new(*args, **kwargs)

    alias.__name__ = old
    alias.__qualname__ = new.__qualname__.rsplit(".", 1)[0] + "." + old if "." in new.__qualname__ else old
    alias.__doc__ = f"Deprecated alias of ``{new.__name__}`` (removed in {removed_in}).\n\n.. deprecated:: 0.2.0\n"
    return alias
