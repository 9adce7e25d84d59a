"""The editing session: lattice, basis, mesh, selection, undo history, surface drags, messages and the list of
the panels' controls, with the commands that change them.

NumPy and the model only: importing this package loads no VTK, PyVista, trame or ipywidgets (a test checks
``sys.modules`` in a fresh interpreter). The scene (:mod:`..scene`) and the two front-ends
(:mod:`..notebook`, :mod:`..app`) follow a session through :meth:`EditingSession.subscribe`.
"""

from __future__ import annotations

from .changes import Change
from .session import FIELDS, POINTS_SHOWN, EditingSession, Field, MeshIO, PointsShown

__all__ = ["FIELDS", "POINTS_SHOWN", "Change", "EditingSession", "Field", "MeshIO", "PointsShown"]
