"""The weight brush: per-vertex weights that say how much of the deformation each vertex follows.

Blender's lattice modifier takes a vertex group: a weight in [0, 1] per vertex scales its displacement
(:attr:`ffd_notebook.FFD.weights`), so "deform the nose, keep the eyes". A session's weights live on
its FFD (``session.ffd.weights``: one per vertex of the mesh, or None when every vertex follows fully).
:class:`WeightPaint` (``session.paint``) edits them: set from code, cleared, or painted with a brush,
where each stroke event raises (or lowers, with a negative amount) the weights within a radius of a
point of the rest mesh, with a smooth falloff. The first stroke on a mesh without weights starts from
zero: only what is painted follows the lattice. A whole stroke, from press to release, is one undo
step, as is setting or clearing them (the history keeps copies of the FFD, weights included).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ....ffd.influence import point_weights
from .lattices import copy_ffd
from .script import BrushStroke

if TYPE_CHECKING:
    from .session import EditingSession

__all__ = ["BRUSH_RADIUS", "WeightPaint", "brush_falloff"]

#: the brush radius by default, as a fraction of the rest mesh's bounding-box diagonal
BRUSH_RADIUS = 0.1


def brush_falloff(distance: NDArray[np.float64], radius: float) -> NDArray[np.float64]:
    """How much of a stroke reaches each vertex: ``(1 - (d / r)^2)^2`` inside the radius, 0 outside.

    Examples
    --------
    >>> brush_falloff(np.array([0.0, 0.5, 1.0, 2.0]), 1.0).tolist()
    [1.0, 0.5625, 0.0, 0.0]
    """
    x = np.clip(1.0 - (distance / radius) ** 2, 0.0, None)
    return x * x


class WeightPaint:
    """The weights of a session's vertices and the brush that paints them (``session.paint``).

    Attributes
    ----------
    radius : float
        Brush radius (world units of the rest mesh).
    amount : float
        What a stroke event adds at the brush's centre (negative: lowers).

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
    >>> from ffd_notebook.view.editor.session import EditingSession
    >>> session = EditingSession(pv.Sphere(), mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
    >>> session.paint.begin()
    >>> session.paint.stroke(session.rest_points[0], amount=1.0)
    >>> session.paint.end()
    >>> w = session.paint.weights
    >>> float(w[0]), float(w.min()), len(session.history)
    (1.0, 0.0, 1)
    """

    def __init__(self, session: EditingSession) -> None:
        self.session = session
        points = session.rest_points
        self.radius = BRUSH_RADIUS * float(np.linalg.norm(np.ptp(points, axis=0))) or 1.0
        self.amount = 0.25
        self._stroke: dict[str, Any] | None = None

    def set_brush(self, direction: str) -> None:
        """Whether a stroke ``"raise"``-s or ``"lower"``-s the weights (the sign of :attr:`amount`)."""
        if direction not in ("raise", "lower"):
            raise ValueError(f"the brush raises or lowers the weights: 'raise' or 'lower', got {direction!r}")
        self.amount = abs(self.amount) if direction == "raise" else -abs(self.amount)
        self.session.notify("display", None, "brush")

    @property
    def weights(self) -> NDArray[np.float64] | None:
        """The vertices' weights (a copy), or None when every vertex follows the lattice fully."""
        w = self.session.ffd.weights
        return None if w is None or isinstance(w, str) else np.array(w, dtype=np.float64)

    def set(self, weights: ArrayLike | None, *, label: str = "weights") -> None:
        """Set every vertex's weight (``(N,)`` in [0, 1]) or None (all follow); one undo step.

        Invalid weights change nothing (a message and a ValueError).
        """
        session = self.session
        try:
            checked = point_weights(weights, len(session.rest_points))
        except ValueError as exc:
            session.error(f"cannot set the weights: {exc}")
            raise
        session.swap_ffd(copy_ffd(session.ffd, weights=checked), label=label, source=session.lattice_source)

    def clear(self) -> None:
        """Remove the weights: every vertex follows the lattice fully again (one undo step)."""
        if self.session.ffd.weights is not None:
            self.set(None, label="clear weights")

    def begin(self) -> None:
        """A brush stroke starts (the mouse was pressed on the mesh in "paint weights" mode)."""
        session = self.session
        session.history.close()
        current = self.weights
        start = np.zeros(len(session.rest_points)) if current is None else current
        self._stroke = {"before": copy_ffd(session.ffd), "weights": start, "dabs": []}

    def stroke(self, point: ArrayLike, *, amount: float | None = None, radius: float | None = None,
               started: float | None = None) -> None:  # fmt: skip
        """Paint at ``point`` (a ``(3,)`` position on the rest mesh): weights within ``radius`` rise by
        ``amount`` times the falloff (:func:`brush_falloff`), kept in [0, 1]. The mesh follows at once."""
        if self._stroke is None:
            self.begin()
        session, stroke = self.session, self._stroke
        centre = np.asarray(point, dtype=np.float64).reshape(3)
        r = self.radius if radius is None else float(radius)
        a = self.amount if amount is None else float(amount)
        if not (np.isfinite(centre).all() and np.isfinite(r) and r > 0 and np.isfinite(a)):
            raise ValueError(f"a brush stroke needs a finite point, a positive radius and a finite amount, got "
                             f"{point!r}, {radius!r}, {amount!r}")  # fmt: skip
        distance = np.linalg.norm(session.rest_points - centre, axis=1)
        assert stroke is not None  # begin() above started one
        w = stroke["weights"]
        np.clip(w + a * brush_falloff(distance, r), 0.0, 1.0, out=w)
        stroke["dabs"].append((centre.copy(), a, r))  # for the script (session.script): the stroke as a loop
        session.deformer.weights = w  # rebinds with the new factors and evaluates
        session.deformed_points = session.deformer.current()
        session.notify("drag", None, "paint weights", started)

    def end(self) -> None:
        """The stroke ends (mouse released): the painted weights become one undo step."""
        stroke, self._stroke = self._stroke, None
        if stroke is None:
            return
        session = self.session
        after = copy_ffd(session.ffd, weights=stroke["weights"].copy())
        session.history.record_lattice((stroke["before"], session.lattice_source), (after, session.lattice_source),
                                       label="paint weights", how=BrushStroke(tuple(stroke["dabs"])))  # fmt: skip
        session.ffd.weights = stroke["weights"].copy()
        session.notify("offsets", None, "paint weights")
