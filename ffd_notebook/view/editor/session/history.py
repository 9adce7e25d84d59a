"""Undo/redo for the editor: a bounded stack of reversible changes (plain Python and NumPy).

Two kinds of change are recorded:

:class:`OffsetEdit`
    Some control points' offsets went from ``before`` to ``after`` (a drag, a typed
    displacement, a reset). Only the touched points are stored, so a long session of drags
    costs a few hundred bytes per step.
:class:`LatticeSwap`
    The whole lattice (and the basis) was replaced: a new lattice size, another basis, a
    loaded .ffd file. Both lattices are kept as copies.

Consecutive moves of the same control point merge into one step while the step is *open*
(``History.record(..., key=...)`` with the same key); :meth:`History.close` ends it. The editor
closes the step when the mouse releases a sphere, and before any other kind of edit, so one drag
is one undo step.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["History", "HistoryStep", "LatticeSwap", "OffsetEdit"]


@dataclass
class OffsetEdit:
    """Offsets of control points ``ijk`` (``(M, 3)`` ints) changed from ``before`` to ``after`` (``(M, 3)``)."""

    ijk: NDArray[np.int64]
    before: NDArray[np.float64]
    after: NDArray[np.float64]
    label: str = "edit"
    #: how the command made it, for code that does the same (:mod:`.script`): e.g. a surface drag's point and target
    how: Any = None


@dataclass
class LatticeSwap:
    """The lattice was replaced: ``before = (ffd, ...)`` (the whole FFD) and ``after`` likewise.

    The tuples are the caller's (the editor adds how the lattice was made); the history only keeps them.
    """

    before: tuple[Any, ...]
    after: tuple[Any, ...]
    label: str = "lattice"
    #: how the command made it, for code that does the same (:mod:`.script`): e.g. the file it loaded
    how: Any = None


#: one undo step (not to be confused with :class:`~.changes.Change`, what a command tells the views)
HistoryStep = OffsetEdit | LatticeSwap


class History:
    """A bounded undo/redo stack.

    Parameters
    ----------
    limit : int
        Most steps kept; the oldest are dropped first.
    on_drop : callable, optional
        Called with each step dropped off the oldest end (what the session's script folds into its start).

    Examples
    --------
    >>> import numpy as np
    >>> h = History()
    >>> h.record([(1, 2, 3)], [(0.0, 0, 0)], [(1.0, 0, 0)], key=5)
    >>> h.record([(1, 2, 3)], [(1.0, 0, 0)], [(2.0, 0, 0)], key=5)   # same drag: merged
    >>> len(h), h.undo().before.tolist(), h.can_redo
    (1, [[0.0, 0.0, 0.0]], True)
    >>> h.redo().after.tolist()
    [[2.0, 0.0, 0.0]]
    """

    def __init__(self, limit: int = 500, on_drop: Callable[[HistoryStep], None] | None = None) -> None:
        if limit < 1:
            raise ValueError(f"limit must be at least 1, got {limit}")
        self.limit = int(limit)
        self.on_drop = on_drop
        self._done: list[HistoryStep] = []
        self._undone: list[HistoryStep] = []
        self._open_key: Any = None

    def __len__(self) -> int:
        return len(self._done)

    @property
    def steps(self) -> tuple[HistoryStep, ...]:
        """The steps done, oldest first (undone steps are not among them)."""
        return tuple(self._done)

    @property
    def can_undo(self) -> bool:
        """Whether there is a step to undo."""
        return bool(self._done)

    @property
    def can_redo(self) -> bool:
        """Whether there is an undone step to redo."""
        return bool(self._undone)

    def record(self, ijk: Any, before: Any, after: Any, key: Any = None, label: str = "edit", how: Any = None) -> None:
        """Record that the offsets of ``ijk`` went from ``before`` to ``after`` (``how``: see :class:`OffsetEdit`).

        With a ``key`` equal to the open step's key, the change merges into that step (the
        step keeps its first ``before`` and takes the new ``after`` and ``how``); otherwise a new step
        starts and stays open for that key. ``key=None`` always makes a closed step of its own.
        """
        ijk_arr = np.array(ijk, dtype=np.int64).reshape(-1, 3)
        before_arr = np.array(before, dtype=np.float64).reshape(-1, 3)
        after_arr = np.array(after, dtype=np.float64).reshape(-1, 3)
        if not (len(ijk_arr) == len(before_arr) == len(after_arr)):
            raise ValueError("ijk, before and after must have the same number of rows")
        self._undone.clear()
        last = self._done[-1] if self._done else None
        if (
            key is not None
            and key == self._open_key
            and isinstance(last, OffsetEdit)
            and np.array_equal(last.ijk, ijk_arr)
        ):
            last.after, last.how = after_arr, how
            return
        self._push(OffsetEdit(ijk_arr, before_arr, after_arr, label, how))
        self._open_key = key

    def record_lattice(
        self, before: tuple[Any, ...], after: tuple[Any, ...], label: str = "lattice", how: Any = None
    ) -> None:
        """Record a whole-lattice replacement (``(ffd, ...)`` tuples, copies; ``how``: see :class:`LatticeSwap`)."""
        self._undone.clear()
        self._push(LatticeSwap(before, after, label, how))
        self._open_key = None

    def close(self) -> None:
        """End the open step: the next change starts a new one even for the same key."""
        self._open_key = None

    def peek(self, forward: bool = False) -> HistoryStep | None:
        """The step :meth:`undo` (or, ``forward``, :meth:`redo`) would pop next, left in place; None if none."""
        steps = self._undone if forward else self._done
        return steps[-1] if steps else None

    def undo(self) -> HistoryStep | None:
        """Pop the last step (to be reverted by the caller); ``None`` if there is none."""
        self._open_key = None
        if not self._done:
            return None
        change = self._done.pop()
        self._undone.append(change)
        return change

    def redo(self) -> HistoryStep | None:
        """Pop the last undone step (to be re-applied by the caller); ``None`` if there is none."""
        self._open_key = None
        if not self._undone:
            return None
        change = self._undone.pop()
        self._done.append(change)
        return change

    def clear(self) -> None:
        """Forget every step."""
        self._done.clear()
        self._undone.clear()
        self._open_key = None

    def _push(self, step: HistoryStep) -> None:
        self._done.append(step)
        if len(self._done) > self.limit:
            dropped = self._done[: len(self._done) - self.limit]
            del self._done[: len(dropped)]
            if self.on_drop is not None:
                for old in dropped:
                    self.on_drop(old)

    def __repr__(self) -> str:
        return f"History(undo={len(self._done)}, redo={len(self._undone)}, limit={self.limit})"
