"""Rendering: plotters made with the headless settings where they help, and cameras framed on a scene.

The camera helpers import PyVista, so they load on first use: ``import ffd_notebook.view`` stays light.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..._util.lazy import lazy_getattr
from .plotters import is_headless, new_plotter

if TYPE_CHECKING:
    from .camera import frame_camera as frame_camera
    from .camera import unit_vector as unit_vector
    from .camera import view_direction as view_direction

_LAZY = {
    "frame_camera": "ffd_notebook.view.rendering.camera",
    "unit_vector": "ffd_notebook.view.rendering.camera",
    "view_direction": "ffd_notebook.view.rendering.camera",
}

__all__ = ["is_headless", "new_plotter", *sorted(_LAZY)]

__getattr__ = lazy_getattr(__name__, _LAZY)
