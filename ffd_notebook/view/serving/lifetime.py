"""How long the view layer's objects live: until their owner (an editor, an explorer, a viewer) goes away.

A notebook user re-runs ``editor = fn.edit()``: the old editor is unreachable, yet everything it made
must go. Three kinds of holders outlive a cell and would keep it, and all it owns, alive forever:

- registries of the process: ipywidgets keeps every widget until it is closed, PyVista every plotter
  until it is closed, trame-rca every view handler until it is unregistered, asyncio every pending task;
- VTK observers: a Python callable given to ``AddObserver`` is held by the C++ object, out of the
  garbage collector's sight, so ``plotter -> interactor -> observer -> owner -> plotter`` is a cycle it
  can never free;
- callbacks of widgets in those registries that close over the owner.

The rule: what such a holder keeps refers to its owner weakly (:func:`weak_method`, :func:`weak_call`),
and the owner has a :class:`Lifetime` whose actions close the registered things (the plotter, the
browser views, the widgets) when the owner is collected, or at once on ``owner.close()``.

Examples
--------
>>> import gc
>>> class Owner:
...     def __init__(self, log):
...         self.lifetime = Lifetime(self, lambda: log.append("released"))
...         self.callback = weak_method(self.ping)   # what a registry would keep
...     def ping(self):
...         return "pong"
>>> log = []
>>> owner = Owner(log)
>>> callback = owner.callback
>>> callback(), log
('pong', [])
>>> del owner; _ = gc.collect()
>>> callback(), log                                 # no asyncio loop runs here: released at once
(None, ['released'])
"""

from __future__ import annotations

import asyncio
import functools
import logging
import weakref
from collections.abc import Callable
from typing import Any, TypeVar

__all__ = ["Lifetime", "return_freed_memory", "weak_call", "weak_method"]

log = logging.getLogger(__name__)

T = TypeVar("T")


def weak_method(method: Callable[..., Any]) -> Callable[..., Any]:
    """A callable for a registry to keep: calls the bound ``method`` while its object lives, then does nothing.

    Examples
    --------
    >>> class A:
    ...     def f(self, x):
    ...         return 2 * x
    >>> a = A(); f = weak_method(a.f)
    >>> f(3)
    6
    >>> del a; f(3) is None
    True
    """
    ref = weakref.WeakMethod(method)

    def call(*args: Any, **kwargs: Any) -> Any:
        bound = ref()
        return None if bound is None else bound(*args, **kwargs)

    return call


def weak_call(owner: T, function: Callable[..., Any]) -> Callable[..., Any]:
    """A callable for a registry to keep: ``function(owner, *args)`` while ``owner`` lives, then nothing.

    ``function`` must not itself refer to ``owner`` (write ``lambda self, v: self.set(v)``, not a closure).

    Examples
    --------
    >>> class A:
    ...     pass
    >>> a = A(); call = weak_call(a, lambda self, x: (type(self).__name__, x))
    >>> call(1)
    ('A', 1)
    >>> del a; call(1) is None
    True
    """
    ref = weakref.ref(owner)

    def call(*args: Any, **kwargs: Any) -> Any:
        target = ref()
        return None if target is None else function(target, *args, **kwargs)

    return call


class Lifetime:
    """Actions that release what ``owner`` made, run once: by :meth:`close`, or when ``owner`` is collected.

    When the owner is collected while an asyncio loop runs (a Jupyter kernel), the actions run at the
    loop's next turn, never inside whatever code the collection interrupted (a render of another
    plotter, a widget callback): closing a render window in the middle of another one's render is not
    safe. Without a running loop they run at once. An action that fails is logged; the others still run.
    The actions must not refer to the owner (or it would never be collected).

    Parameters
    ----------
    owner : object
        Whose lifetime this is (weakly referenced).
    *actions : callable
        Called without arguments, in order.
    """

    def __init__(self, owner: object, *actions: Callable[[], Any]) -> None:
        self.actions: list[Callable[[], Any]] = list(actions)
        self._finalizer = weakref.finalize(owner, _release_later, self.actions, _running_loop())
        self._finalizer.atexit = False  # at exit PyVista closes its plotters itself

    def add(self, action: Callable[[], Any]) -> None:
        """Run ``action`` too (after the others)."""
        self.actions.append(action)

    @property
    def alive(self) -> bool:
        """Whether the actions have not run (nor been scheduled) yet."""
        return self._finalizer.alive

    def close(self) -> None:
        """Run the actions now (once: later calls, and the owner's collection, do nothing)."""
        if self._finalizer.detach() is not None:
            _release(self.actions)


def _running_loop() -> asyncio.AbstractEventLoop | None:
    try:
        return asyncio.get_running_loop()
    except RuntimeError:
        return None


def _release(actions: list[Callable[[], Any]]) -> None:
    while actions:
        action = actions.pop(0)
        try:
            action()
        except Exception:
            log.exception("releasing %r failed", action)
    return_freed_memory()


@functools.cache
def _malloc_trim() -> Callable[[int], int] | None:
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("c")
    try:
        return getattr(ctypes.CDLL(name), "malloc_trim", None) if name else None
    except OSError:  # pragma: no cover - no C library to load
        return None


def return_freed_memory() -> None:
    """Give the memory freed inside the C heap back to the system (glibc's ``malloc_trim``; elsewhere nothing).

    A released scene frees tens of MB in many VTK and Mesa buffers; glibc keeps free memory inside its heap
    for reuse, so without this the kernel's size (what the user's system monitor shows) stayed at its high
    water mark: about 30 MB more after a few re-runs of a GP explorer cell, all of it free.
    """
    trim = _malloc_trim()
    if trim is not None:
        trim(0)


def _release_later(actions: list[Callable[[], Any]], loop: asyncio.AbstractEventLoop | None) -> None:
    """The finalizer: release at the next turn of the loop running here, or of the owner's loop if it runs in
    another thread, or now."""
    here = _running_loop()
    if here is not None:
        here.call_soon(_release, actions)
    elif loop is not None and loop.is_running() and not loop.is_closed():
        loop.call_soon_threadsafe(_release, actions)
    else:
        _release(actions)
