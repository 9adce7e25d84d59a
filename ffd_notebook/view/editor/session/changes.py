"""What an editing session tells its views: one :class:`Change` per command, to every subscriber.

This is the editor's single change-notification path from the model outward. The session is the
only writer of the lattice's offsets inside the editor, and every command knows which control
points it wrote: it says so in :attr:`Change.points`, so no view ever compares copies of the offsets.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray

__all__ = ["DRAG_SYNC_S", "KINDS", "Change", "DragSync", "Subscribers"]

Kind = Literal["drag", "offsets", "lattice", "mesh", "select", "display", "message", "image"]
#: ``"drag"``: offsets changed while a handle is held (the handle is already where the mouse is);
#: ``"offsets"``: a finished offsets edit; ``"lattice"``: a new lattice (or basis); ``"mesh"``: a new
#: mesh; ``"select"``: the selected control point; ``"display"``: coloring; ``"message"``: a new message;
#: ``"image"``: an image loaded, its slices moved or its window changed (``session.image``).
KINDS: tuple[str, ...] = ("drag", "offsets", "lattice", "mesh", "select", "display", "message", "image")

#: while something is dragged, the panels follow at most this often: each sync is messages to the page
#: (in JupyterLab, widget updates that Lab's page handles on the same thread as the view's frames)
DRAG_SYNC_S = 0.25


@dataclass(frozen=True)
class Change:
    """What one session command changed.

    Parameters
    ----------
    kind : str
        One of :data:`KINDS`; any other value raises ValueError.
    points : array_like of int, optional
        Flat indices of the changed control points (stored as a 1-D ``numpy.intp`` array); ``None`` for all.
    label : str, default ""
        The command's name.
    started : float, optional
        When the command began; by default :func:`time.perf_counter` at creation.

    Attributes
    ----------
    kind : str
        One of :data:`KINDS`.
    points : numpy.ndarray or None
        For ``"drag"`` and ``"offsets"``: flat C-order indices of the control points whose offsets
        changed (the row of ``lattice.offsets.reshape(-1, 3)``, the index the drag callbacks get); ``None``
        means all of them.
    label : str
        The command (``"drag"``, ``"move"``, ``"reset"``, ``"code"``, ``"undo"``, ``"load mesh"``...).
    started : float
        :func:`time.perf_counter` when the command began (callback timing).

    Examples
    --------
    >>> Change("offsets", points=[3, 1], label="reset").points.tolist()
    [3, 1]
    """

    kind: Kind
    points: NDArray[np.intp] | None = None
    label: str = ""
    started: float = field(default_factory=time.perf_counter)

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, got {self.kind!r}")
        if self.points is not None:
            object.__setattr__(self, "points", np.asarray(self.points, dtype=np.intp).reshape(-1))


class Subscribers:
    """Callbacks that follow a session, called in subscription order.

    A callback that raises does not stop the others: ``report(text)`` receives
    ``"Error: a view failed to follow the editor: ..."`` (the session appends it to its messages
    without a new notification, so a failing view cannot recurse).

    Examples
    --------
    >>> seen, errors = [], []
    >>> subs = Subscribers(errors.append)
    >>> stop = subs.add(lambda c: seen.append(c.kind))
    >>> _ = subs.add(lambda c: 1 / 0)
    >>> subs.emit(Change("select"))
    >>> seen, errors[0][:45]
    (['select'], 'Error: a view failed to follow the editor: Ze')
    >>> stop(); subs.emit(Change("select")); seen
    ['select']
    """

    def __init__(self, report: Callable[[str], None]) -> None:
        self._callbacks: list[Callable[[Change], None]] = []
        self._report = report

    def add(self, callback: Callable[[Change], None]) -> Callable[[], None]:
        """Subscribe ``callback``; returns a function that unsubscribes it."""
        self._callbacks.append(callback)
        return lambda: self._callbacks.remove(callback) if callback in self._callbacks else None

    def emit(self, change: Change) -> None:
        """Tell every subscriber about ``change``."""
        for callback in list(self._callbacks):
            try:
                callback(change)
            except Exception as exc:
                self._report(f"Error: a view failed to follow the editor: {exc!r}")

    def clear(self) -> None:
        """Unsubscribe everybody (the editor is closing)."""
        self._callbacks.clear()


class DragSync:
    """Which changes a panel follows: every change, but ``"drag"`` changes at most every ``period`` seconds.

    The change that ends a drag is an ``"offsets"`` one, so the panel shows the final state.

    Examples
    --------
    >>> sync = DragSync(period=10.0)
    >>> [sync.wanted(Change(kind)) for kind in ("drag", "drag", "offsets", "drag")]
    [True, False, True, False]
    """

    def __init__(self, period: float = DRAG_SYNC_S) -> None:
        self.period = period
        self._last = -float("inf")

    def wanted(self, change: Change) -> bool:
        """Whether to sync the panel for ``change``."""
        if change.kind != "drag":
            return True
        now = time.monotonic()
        if now - self._last < self.period:
            return False
        self._last = now
        return True
