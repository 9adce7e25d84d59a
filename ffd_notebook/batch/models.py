"""Random lattice deformations with TorchIO's parameter names, and the sample they produce.

A model is a small frozen object describing a distribution. ``model.bind(points)`` fits it to a
mesh's vertices (here: a lattice around them) and returns a *bound model* whose
``draw(rng, index)`` gives one :class:`LatticeSample`. Every model also has ``to_spec()`` (plain
JSON values, stored in the run folder) and the module-level :func:`model_from_spec` rebuilds it.
NumPy only: no VTK here.
"""

from __future__ import annotations

import inspect
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..deform import BASES, FFD
from ..lattice import Lattice

__all__ = ["BORDERS", "LatticeSample", "RandomLattice", "make_ffd"]

BORDERS = ("zero", "clamp")


def make_ffd(lattice: Lattice, basis: str = "bspline", border: str = "zero", affine: Any = None) -> FFD:
    """``FFD(lattice, basis, affine)``, passing ``border`` only when it is not the default ``"zero"``.

    The ``border`` argument of :class:`~ffd_notebook.FFD` is newer than this module; with an FFD
    that does not take it, ``border="clamp"`` is a clear ``ValueError`` instead of a ``TypeError``.

    Examples
    --------
    >>> from ffd_notebook import Lattice
    >>> make_ffd(Lattice((4, 4, 4), 1.0)).basis
    'bspline'
    """
    if border not in BORDERS:
        raise ValueError(f"border must be one of {BORDERS}, got {border!r}")
    if border == "zero":
        return FFD(lattice, basis=basis, affine=affine)
    if "border" not in inspect.signature(FFD).parameters:
        raise ValueError(f"border={border!r} needs an FFD that takes a border rule; this version has only 'zero'")
    return FFD(lattice, basis=basis, border=border, affine=affine)  # type: ignore[call-arg]


def _fit_lattice(points: NDArray[np.float64], shape: tuple[int, int, int], margin: float, basis: str, border: str):
    """``Lattice.around`` with the border rule passed on only when it is not ``"zero"`` (see :func:`make_ffd`)."""
    if border == "zero":
        return Lattice.around(points, shape=shape, margin=margin, basis=basis)
    if "border" not in inspect.signature(Lattice.around).parameters:
        raise ValueError(f"border={border!r} needs a Lattice.around that takes a border rule")
    return Lattice.around(points, shape=shape, margin=margin, basis=basis, border=border)  # type: ignore[call-arg]


def _triple(value: Any, name: str, kind: type) -> tuple:
    """A scalar or three values, as a tuple of three ``kind`` (TorchIO accepts both)."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        arr = np.repeat(arr, 3)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be one number or three finite numbers, got {value!r}")
    if kind is int and not np.all(arr == np.round(arr)):
        raise ValueError(f"{name} must be integers, got {value!r}")
    return tuple(kind(v) for v in arr)


@dataclass(frozen=True)
class LatticeSample:
    """One drawn deformation: an FFD, and the factor its lattice offsets were scaled by.

    Attributes
    ----------
    ffd : FFD
        The deformation (its lattice holds the drawn offsets).
    scale : float
        1.0 unless the fold check scaled the draw down.
    """

    ffd: FFD
    scale: float = 1.0

    def deform(self, points: ArrayLike) -> NDArray[np.float64]:
        """Deformed ``(N, 3)`` points (:meth:`FFD.deform`)."""
        return self.ffd.deform(points)

    def jacobian_determinant(self, points: ArrayLike) -> NDArray[np.float64]:
        """The exact (analytic) Jacobian determinant of the FFD at each point."""
        return self.ffd.jacobian_determinant(points)

    def scaled(self, factor: float) -> LatticeSample:
        """The same draw with every offset multiplied by ``factor`` (the affine part kept)."""
        lattice = self.ffd.lattice.copy()
        lattice.offsets *= factor
        border = getattr(self.ffd, "border", "zero")
        return LatticeSample(make_ffd(lattice, self.ffd.basis, border, self.ffd.affine), self.scale * factor)


@dataclass(frozen=True)
class RandomLattice:
    """A random B-spline (or Bernstein) lattice around the mesh, TorchIO's ``RandomElasticDeformation`` for meshes.

    The lattice has ``num_control_points`` per axis and is fitted around the mesh with
    :meth:`Lattice.around` (for B-splines the outer ring lies one spacing outside the mesh's
    box, as in TorchIO where it lies outside the image). Each control point's offset along
    axis ``a`` is drawn independently from ``Uniform(-max_displacement[a], max_displacement[a])``
    (world units, TorchIO's ``(rand - 0.5) * 2 * max_displacement``). ``locked_borders`` sets
    offsets to zero on the outer layers: 0 none, 1 the outermost control points, 2 those and
    the next layer (TorchIO's default; for B-splines that layer sits on the mesh's bounding box,
    like TorchIO's control points on the image border, and a point on the box's faces keeps at
    most a sixth of the displacement).

    Parameters
    ----------
    num_control_points : int or three ints
        Control points per axis; at least 4 for B-splines, 2 for Bernstein.
    max_displacement : float or three floats
        Largest offset per axis, world units, ``>= 0``.
    locked_borders : {0, 1, 2}
        Layers of border control points held at zero.
    basis : {"bspline", "bernstein"}
        The FFD basis.
    border : {"zero", "clamp"}
        How control points beyond the lattice count: ``"zero"`` (the seed formula, ITK's) or
        ``"clamp"`` (the border control points extend outward; needs an FFD that has it).
    margin : float
        Room around the mesh as a fraction of its largest extent (:meth:`Lattice.around`).

    Examples
    --------
    >>> import numpy as np
    >>> model = RandomLattice(num_control_points=5, max_displacement=0.1, locked_borders=1)
    >>> bound = model.bind(np.random.default_rng(0).random((100, 3)))
    >>> sample = bound.draw(np.random.default_rng(1), 0)
    >>> offsets = sample.ffd.lattice.offsets
    >>> bool(np.all(offsets[0] == 0) and np.abs(offsets).max() <= 0.1)
    True
    >>> RandomLattice(num_control_points=3)
    Traceback (most recent call last):
    ...
    ValueError: the cubic B-spline basis needs at least 4 control points per axis, got (3, 3, 3)
    """

    num_control_points: int | tuple[int, int, int] = 7
    max_displacement: float | tuple[float, float, float] = 7.5
    locked_borders: int = 2
    basis: str = "bspline"
    border: str = "zero"
    margin: float = 0.05

    name = "random-lattice"

    def __post_init__(self) -> None:
        shape = _triple(self.num_control_points, "num_control_points", int)
        if self.basis not in BASES:
            raise ValueError(f"basis must be one of {BASES}, got {self.basis!r}")
        least = 4 if self.basis == "bspline" else 2
        if min(shape) < least:
            raise ValueError(
                f"the {'cubic B-spline' if least == 4 else 'Bernstein'} basis needs at least {least} "
                f"control points per axis, got {shape}"
            )
        disp = _triple(self.max_displacement, "max_displacement", float)
        if min(disp) < 0:
            raise ValueError(f"max_displacement must be >= 0, got {self.max_displacement!r}")
        if self.locked_borders not in (0, 1, 2):
            raise ValueError(f"locked_borders must be 0, 1 or 2, got {self.locked_borders!r}")
        if min(shape) <= 2 * self.locked_borders:
            raise ValueError(f"locked_borders={self.locked_borders} locks every control point of a {shape} lattice")
        if not (np.isfinite(self.margin) and self.margin >= 0):
            raise ValueError(f"margin must be >= 0, got {self.margin!r}")
        make_ffd(Lattice((4, 4, 4), 1.0), self.basis, self.border)  # an unknown or unsupported border fails here
        object.__setattr__(self, "num_control_points", shape)
        object.__setattr__(self, "max_displacement", disp)

    def to_spec(self) -> dict[str, Any]:
        """The parameters as JSON values, with the model's name under ``"model"``."""
        return {"model": self.name, **{k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}}

    def bind(self, points: ArrayLike) -> BoundLattice:
        """Fit the lattice around the points (a mesh's vertices)."""
        pts = np.asarray(points, dtype=np.float64)
        lattice = _fit_lattice(pts, self.num_control_points, self.margin, self.basis, self.border)  # type: ignore[arg-type]
        return BoundLattice(self, lattice)


@dataclass(frozen=True)
class BoundLattice:
    """A :class:`RandomLattice` fitted to a mesh: draws :class:`LatticeSample` objects."""

    model: RandomLattice
    lattice: Lattice

    def draw(self, rng: np.random.Generator, index: int) -> LatticeSample:
        """One random lattice (``index`` is not used: every draw comes from ``rng``)."""
        shape = self.lattice.shape
        offsets = rng.uniform(-1.0, 1.0, size=(*shape, 3)) * np.asarray(self.model.max_displacement)
        lock = self.model.locked_borders
        if lock:
            free = np.zeros(shape, dtype=bool)
            free[lock:-lock, lock:-lock, lock:-lock] = True
            offsets[~free] = 0.0
        return LatticeSample(self.sample_ffd(offsets))

    def sample_ffd(self, offsets: ArrayLike) -> FFD:
        """An FFD on a copy of the fitted lattice with the given offsets."""
        lattice = self.lattice.copy()
        lattice.set_offsets(offsets)
        return make_ffd(lattice, self.model.basis, self.model.border)
