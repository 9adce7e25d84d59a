"""The FFD editor, in layers:

:mod:`.session`
    The editing session (NumPy and the model, no VTK): state, commands, undo history, surface drags,
    messages, and the list of controls both front-ends draw.
:mod:`.scene`
    The VTK scene that follows a session: plotter, actors, picking.
:class:`~.editor.Editor` (:mod:`.editor`)
    What a notebook user holds: a session shown in a scene, with the notebook widget.
:mod:`.notebook`, :mod:`.app`
    The two front-ends: the Jupyter panel and the standalone trame app.

Names are imported on first use: ``from ffd_notebook.view.editor import EditingSession`` loads no VTK.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..._util.lazy import lazy_getattr

if TYPE_CHECKING:  # the lazy names below, declared for type checkers and IDEs
    from .animation import animate as animate
    from .app import EditorApp as EditorApp
    from .app import run_app as run_app
    from .editor import Editor as Editor
    from .editor import edit as edit
    from .notebook import ControlPanel as ControlPanel
    from .session import Change as Change
    from .session import EditingSession as EditingSession
    from .session import Field as Field
    from .session import MeshIO as MeshIO
    from .session import PointsShown as PointsShown

_LAZY = {
    "Change": "ffd_notebook.view.editor.session",
    "EditingSession": "ffd_notebook.view.editor.session",
    "MeshIO": "ffd_notebook.view.editor.session",
    "Field": "ffd_notebook.view.editor.session",
    "PointsShown": "ffd_notebook.view.editor.session",
    "Editor": "ffd_notebook.view.editor.editor",
    "edit": "ffd_notebook.view.editor.editor",
    "ControlPanel": "ffd_notebook.view.editor.notebook",
    "EditorApp": "ffd_notebook.view.editor.app",
    "run_app": "ffd_notebook.view.editor.app",
    "animate": "ffd_notebook.view.editor.animation",
}

__all__ = sorted(_LAZY)


__getattr__ = lazy_getattr(__name__, _LAZY)
