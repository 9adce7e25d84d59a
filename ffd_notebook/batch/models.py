"""Random lattice deformations with TorchIO's parameter names, and the sample they produce.

A model is a small frozen object describing a distribution. ``model.bind(points)`` fits it to a
mesh's vertices (here: a lattice around them) and returns a *bound model* whose
``draw(rng, index)`` gives one :class:`LatticeSample`. Every model also has ``to_spec()`` (plain
JSON values, stored in the run folder) and the module-level :func:`model_from_spec` rebuilds it.
NumPy only: no VTK here.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..ffd.basis import BASES, BasisName
from ..ffd.deform import FFD
from ..ffd.lattice import Lattice
from ..ffd.support import Border, check_border

__all__ = ["LatticeSample", "RandomLattice"]


def as_triple(value: Any, name: str, kind: type) -> tuple:
    """A scalar or three values, as a tuple of three ``kind`` (TorchIO accepts both).

    Examples
    --------
    >>> as_triple(5, "num_control_points", int), as_triple([1, 2, 3.5], "max_displacement", float)
    ((5, 5, 5), (1.0, 2.0, 3.5))
    """
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

    Parameters
    ----------
    ffd : FFD
        The deformation (its lattice holds the drawn offsets).
    scale : float
        1.0 unless the fold check scaled the draw down.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook import FFD, Lattice
    >>> from ffd_notebook.batch import LatticeSample
    >>> lat = Lattice((4, 4, 4), 1.0)
    >>> lat.offsets[1, 1, 1] = (0.2, 0.0, 0.0)
    >>> sample = LatticeSample(FFD(lat))
    >>> sample.scaled(0.5).scale
    0.5
    """

    ffd: FFD
    scale: float = 1.0

    def deform(self, points: ArrayLike) -> NDArray[np.float64]:
        """Deformed ``(N, 3)`` points (:meth:`FFD.deform`).

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` deformed points.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import FFD, Lattice
        >>> from ffd_notebook.batch import LatticeSample
        >>> lat = Lattice((4, 4, 4), 1.0)
        >>> lat.offsets[1, 1, 1] = (0.2, 0.0, 0.0)
        >>> sample = LatticeSample(FFD(lat))
        >>> sample.deform([[1.0, 1.0, 1.0]]).round(4).tolist()
        [[1.0593, 1.0, 1.0]]
        """
        return self.ffd.deform(points)

    def jacobian_determinant(self, points: ArrayLike) -> NDArray[np.float64]:
        """The exact (analytic) Jacobian determinant of the FFD at each point.

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points.

        Returns
        -------
        numpy.ndarray
            ``(N,)`` determinants; ``<= 0`` where the deformation folds.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import FFD, Lattice
        >>> from ffd_notebook.batch import LatticeSample
        >>> lat = Lattice((4, 4, 4), 1.0)
        >>> lat.offsets[1, 1, 1] = (0.2, 0.0, 0.0)
        >>> sample = LatticeSample(FFD(lat))
        >>> bool(sample.jacobian_determinant([[1.0, 1.0, 1.0]])[0] > 0)
        True
        """
        return self.ffd.jacobian_determinant(points)

    def scaled(self, factor: float) -> LatticeSample:
        """The same draw with every offset multiplied by ``factor`` (the affine part kept).

        Parameters
        ----------
        factor : float
            What to multiply the offsets by.

        Returns
        -------
        LatticeSample
            A new sample (this one is not changed), its ``scale`` multiplied by ``factor``.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook import FFD, Lattice
        >>> from ffd_notebook.batch import LatticeSample
        >>> lat = Lattice((4, 4, 4), 1.0)
        >>> lat.offsets[1, 1, 1] = (0.2, 0.0, 0.0)
        >>> sample = LatticeSample(FFD(lat))
        >>> half = sample.scaled(0.5)
        >>> half.ffd.lattice.offsets[1, 1, 1].tolist(), sample.ffd.lattice.offsets[1, 1, 1].tolist()
        ([0.1, 0.0, 0.0], [0.2, 0.0, 0.0])
        """
        ffd = self.ffd.copy()  # every option kept: only the offsets are scaled
        ffd.lattice.offsets *= factor
        return LatticeSample(ffd, self.scale * factor)


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
        ``"clamp"`` (the border control points extend outward, so the lattice hugs the mesh's box;
        see :meth:`Lattice.around`). A saved sample's ``.ffd`` records it in a ``#border#`` section.
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
    basis: BasisName = "bspline"
    border: Border = "zero"
    margin: float = 0.05

    name = "random-lattice"

    def __post_init__(self) -> None:
        shape = as_triple(self.num_control_points, "num_control_points", int)
        if self.basis not in BASES:
            raise ValueError(f"basis must be one of {BASES}, got {self.basis!r}")
        least = 4 if self.basis == "bspline" else 2
        if min(shape) < least:
            raise ValueError(
                f"the {'cubic B-spline' if least == 4 else 'Bernstein'} basis needs at least {least} "
                f"control points per axis, got {shape}"
            )
        disp = as_triple(self.max_displacement, "max_displacement", float)
        if min(disp) < 0:
            raise ValueError(f"max_displacement must be >= 0, got {self.max_displacement!r}")
        if self.locked_borders not in (0, 1, 2):
            raise ValueError(f"locked_borders must be 0, 1 or 2, got {self.locked_borders!r}")
        if min(shape) <= 2 * self.locked_borders:
            raise ValueError(f"locked_borders={self.locked_borders} locks every control point of a {shape} lattice")
        if not (np.isfinite(self.margin) and self.margin >= 0):
            raise ValueError(f"margin must be >= 0, got {self.margin!r}")
        check_border(self.border)
        object.__setattr__(self, "num_control_points", shape)
        object.__setattr__(self, "max_displacement", disp)

    def to_spec(self) -> dict[str, Any]:
        """The parameters as JSON values, with the model's name under ``"model"``.

        Returns
        -------
        dict
            JSON-serialisable: what ``manifest``/``settings.json`` record and ``model_from_spec`` reads.

        Examples
        --------
        >>> from ffd_notebook.batch import RandomLattice
        >>> spec = RandomLattice(num_control_points=5).to_spec()
        >>> spec["model"], spec["num_control_points"], spec["border"]
        ('random-lattice', [5, 5, 5], 'zero')
        """
        return {"model": self.name, **{k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}}

    def bind(self, points: ArrayLike) -> BoundLattice:
        """Fit the lattice around the points (a mesh's vertices).

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points.

        Returns
        -------
        BoundLattice
            The model on those points: ``draw(rng, index)`` gives a :class:`LatticeSample`.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.batch import RandomLattice, sample_rng
        >>> pts = np.random.default_rng(0).random((100, 3)) * 10
        >>> bound = RandomLattice(num_control_points=5, max_displacement=1.0).bind(pts)
        >>> sample = bound.draw(sample_rng(0, 3), 3)
        >>> sample.ffd.lattice.shape, sample.deform(pts).shape
        ((5, 5, 5), (100, 3))
        """
        pts = np.asarray(points, dtype=np.float64)
        lattice = Lattice.around(
            pts, shape=self.num_control_points, margin=self.margin, basis=self.basis, border=self.border
        )
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
        return FFD(lattice, basis=self.model.basis, border=self.model.border)
