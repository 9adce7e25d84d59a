"""Plotters made for the machine they run on.

On Linux with no display and no GPU, VTK renders off-screen through EGL and Mesa's software
rasteriser. There, asking for the EGL window avoids VTK first trying X11 (and printing "bad X
server connection"), and turning multi-sampling off makes frames ~3x faster. These settings are
applied to the plotters the package makes (:func:`new_plotter`), never to PyVista's or the
process's global settings: importing the package changes no environment variable and no
``pyvista.global_theme`` setting, and a user's own plots are left as they are. On a desktop
(macOS, Windows, Linux with a display or a GPU) nothing is changed.
"""

from __future__ import annotations

import os
import sys
import threading
from typing import Any

__all__ = ["headless_settings_apply", "is_headless", "new_plotter"]

#: VTK reads this environment variable when it creates a render window
WINDOW_VARIABLE = "VTK_DEFAULT_OPENGL_WINDOW"
_WINDOW_LOCK = threading.Lock()  # the variable is set only while one of our windows is being made


def is_headless() -> bool:
    """True on Linux with no X11/Wayland display (a server, a container, CI).

    Returns
    -------
    bool
        ``True`` when no display is set on Linux; always ``False`` on other systems.

    Examples
    --------
    >>> isinstance(is_headless(), bool)
    True
    """
    if not sys.platform.startswith("linux"):
        return False
    return not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def headless_settings_apply(force: bool | None = None) -> bool:
    """Whether :func:`new_plotter` applies the headless settings: on a headless machine
    (:func:`is_headless`) unless the environment variable ``FFD_NOTEBOOK_NO_HEADLESS=1`` opts out;
    ``force`` decides instead when given.

    Examples
    --------
    >>> headless_settings_apply(force=False), headless_settings_apply(force=True)
    (False, True)
    """
    if force is not None:
        return bool(force)
    return is_headless() and os.environ.get("FFD_NOTEBOOK_NO_HEADLESS") != "1"


def new_plotter(*, headless: bool | None = None, **kwargs: Any) -> Any:
    """A new ``pyvista.Plotter(**kwargs)``; on a headless machine, with an EGL render window and no multi-sampling.

    The EGL window is asked for through ``VTK_DEFAULT_OPENGL_WINDOW`` only while the window is made
    (a value the user set is kept), and multi-sampling is turned off on this plotter's window
    only, so neither the environment nor ``pyvista.global_theme`` changes.

    Parameters
    ----------
    headless : bool, optional
        Apply the headless settings (``True``), or not (``False``); ``None`` decides by
        :func:`headless_settings_apply`.
    **kwargs
        Passed to :class:`pyvista.Plotter`.

    Returns
    -------
    pyvista.Plotter
        The new plotter (off-screen plotters render into an EGL window when headless).

    Examples
    --------
    >>> import os
    >>> before = dict(os.environ)
    >>> pl = new_plotter(off_screen=True, window_size=(64, 48), headless=True)
    >>> pl.render_window.GetMultiSamples(), dict(os.environ) == before
    (0, True)
    >>> pl.close()
    """
    import pyvista as pv

    if not headless_settings_apply(headless):
        return pv.Plotter(**kwargs)
    with _WINDOW_LOCK:
        preset = os.environ.get(WINDOW_VARIABLE)
        if preset is None:
            os.environ[WINDOW_VARIABLE] = "vtkEGLRenderWindow"
        try:
            plotter = pv.Plotter(**kwargs)
        finally:
            if preset is None:
                os.environ.pop(WINDOW_VARIABLE, None)
    # Mesa's software rasteriser pays ~3.5x per frame for anti-aliasing (read at the window's first render)
    plotter.render_window.SetMultiSamples(0)
    return plotter
