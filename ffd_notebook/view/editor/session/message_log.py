"""The editor's message log: the newest messages only, so a long session does not grow without bound."""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable

__all__ = ["MAX_MESSAGES", "MessageLog"]

MAX_MESSAGES = 500


class MessageLog(deque):
    """A :class:`collections.deque` of message strings with a ``maxlen``, newest last.

    Like a list it can also be sliced (``log[-10:]`` gives a list), which the panels use, and it
    counts every message ever added (:attr:`n_added`), since its length stops changing once full.

    Examples
    --------
    >>> log = MessageLog(maxlen=3)
    >>> for n in range(5):
    ...     log.append(f"message {n}")
    >>> list(log), log[-1], log[-2:], log.n_added
    (['message 2', 'message 3', 'message 4'], 'message 4', ['message 3', 'message 4'], 5)
    """

    def __init__(self, iterable: Iterable[str] = (), maxlen: int | None = MAX_MESSAGES) -> None:
        super().__init__((), maxlen)
        self.n_added = 0
        self.extend(iterable)

    def append(self, text: str) -> None:
        super().append(text)
        self.n_added += 1

    def extend(self, texts: Iterable[str]) -> None:
        for text in texts:
            self.append(text)

    def __getitem__(self, index):
        if isinstance(index, slice):
            return list(self)[index]
        return super().__getitem__(index)
