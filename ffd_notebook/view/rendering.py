"""Rendering settings that depend on the machine.

On Linux with no display and no GPU, VTK renders off-screen through EGL and Mesa's software
rasteriser. There, selecting the EGL window up front avoids VTK first trying X11 (and printing
"bad X server connection"), and turning multi-sampling off makes frames ~3x faster. On a
desktop (macOS, Windows, Linux with a display or a GPU) nothing is changed.
"""

from __future__ import annotations

import os
import sys

__all__ = ["configure_rendering", "is_headless"]


def is_headless() -> bool:
    """True on Linux with no X11/Wayland display (a server, a container, CI).

    Examples
    --------
    >>> isinstance(is_headless(), bool)
    True
    """
    if not sys.platform.startswith("linux"):
        return False
    return not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def configure_rendering(force: bool | None = None) -> bool:
    """Apply the headless settings if this machine is headless; return whether they were applied.

    Must run before the first render window is created (``ffd_notebook.view`` calls it on
    import). Users can opt out with the environment variable ``FFD_NOTEBOOK_NO_HEADLESS=1``
    or force it with ``force=True``.

    Parameters
    ----------
    force : bool, optional
        ``True`` to apply the settings anyway, ``False`` to skip them; ``None`` decides by
        :func:`is_headless`.
    """
    apply = is_headless() if force is None else force
    if os.environ.get("FFD_NOTEBOOK_NO_HEADLESS") == "1" and force is None:
        apply = False
    if not apply:
        return False
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    # Mesa's software rasteriser pays ~3.5x per frame for anti-aliasing
    pv.global_theme.multi_samples = 0
    return True
