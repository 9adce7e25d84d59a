"""Random deformations from a low-rank Gaussian process (Gaussian or cubic B-spline kernel).

The model is built on the mesh's vertices by :meth:`LowRankGP.nystrom` with a seeded choice of
inducing points, so every worker (and :func:`~ffd_notebook.batch.replay`) rebuilds the same
basis from the same spec. A sample is its ``rank`` standard-normal coefficients; the deformed
position of a point is ``x + instance(c, x)``. NumPy/SciPy only.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..ffd.lattice import Lattice
from ..gp import BSplineKernel, GaussianKernel, GaussianProcess, Kernel, LowRankGP
from .models import as_triple

__all__ = ["GPSample", "RandomGP"]

BATCH_GP_KERNELS = ("gaussian", "bspline")


@dataclass(frozen=True)
class RandomGP:
    """Samples of a low-rank Gaussian process over the mesh: smooth random displacement fields.

    The displacement is ``u(x) = sum_k sqrt(lambda_k) c_k phi_k(x)`` with ``c_k ~ N(0, 1)``
    i.i.d. over the ``rank`` leading eigenfunctions of the kernel on the mesh's vertices
    (Nystrom with ``n_inducing`` inducing vertices chosen by ``seed``).

    Parameters
    ----------
    kernel : {"gaussian", "bspline"}
        ``"gaussian"``: ``scale^2 exp(-|x - y|^2 / sigma^2)``. ``"bspline"``: the covariance of a
        random cubic B-spline FFD on a lattice of ``num_control_points`` around the mesh whose
        offsets are i.i.d. ``N(0, scale^2)``.
    scale : float
        Standard deviation of each displacement component (Gaussian) or control-point offset
        component (B-spline), world units.
    sigma : float
        Width of the Gaussian kernel, world units (unused by the B-spline kernel).
    num_control_points : int or three ints
        Lattice size of the B-spline kernel, one count for every axis or one per axis (each at least 4).
    rank, n_inducing : int
        Basis functions kept; inducing points of the Nystrom approximation.
    seed : int
        Chooses the inducing points (part of the model, not of a sample).

    Notes
    -----
    The Jacobian determinant of a sample is taken by central differences of the field with step
    ``1e-4`` of the mesh's largest extent (the ``gp`` kernels have no derivatives); for the smooth
    kernels here its error is far below any sensible fold threshold.

    Examples
    --------
    >>> import numpy as np
    >>> pts = np.random.default_rng(0).random((400, 3))
    >>> bound = RandomGP(kernel="gaussian", sigma=0.5, scale=0.01, rank=10, n_inducing=40).bind(pts)
    >>> sample = bound.draw(np.random.default_rng(1), 0)
    >>> sample.coefficients.shape, bool(np.all(sample.jacobian_determinant(pts[:5]) > 0.9))
    ((10,), True)
    """

    kernel: str = "gaussian"
    scale: float = 5.0
    sigma: float = 50.0
    num_control_points: int | tuple[int, int, int] = 7
    rank: int = 50
    n_inducing: int = 300
    seed: int = 0

    name = "gp"

    def __post_init__(self) -> None:
        if self.kernel not in BATCH_GP_KERNELS:
            raise ValueError(f"kernel must be one of {BATCH_GP_KERNELS}, got {self.kernel!r}")
        for field in ("scale", "sigma"):
            value = getattr(self, field)
            if not (isinstance(value, int | float) and np.isfinite(value) and value > 0):
                raise ValueError(f"{field} must be a positive number, got {value!r}")
        count = self.num_control_points
        shape = as_triple(count, "num_control_points", int)  # one number or three, as RandomLattice's
        if self.kernel == "bspline" and min(shape) < 4:
            raise ValueError(f"the B-spline kernel needs num_control_points >= 4 per axis, got {count!r}")
        # three numbers (a spec's list too): a tuple; one number stays one (the run.json of earlier runs)
        object.__setattr__(self, "num_control_points", shape if np.ndim(count) else shape[0])
        for field in ("rank", "n_inducing"):
            if not (isinstance(getattr(self, field), int) and getattr(self, field) >= 1):
                raise ValueError(f"{field} must be a positive integer, got {getattr(self, field)!r}")

    def to_spec(self) -> dict[str, Any]:
        """The parameters as JSON values, with the model's name under ``"model"``.

        Returns
        -------
        dict
            JSON-serialisable: what the run records and ``model_from_spec`` reads back.

        Examples
        --------
        >>> spec = RandomGP(sigma=20.0, scale=2.0).to_spec()
        >>> spec["model"], spec["kernel"], spec["sigma"]
        ('gp', 'gaussian', 20.0)
        """
        return {"model": self.name, **{k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}}

    def bind(self, points: ArrayLike) -> BoundGP:
        """Build the low-rank model on the points (a mesh's vertices).

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points (a mesh's vertices).

        Returns
        -------
        BoundGP
            The model on those points: ``draw(rng, index)`` gives a sample.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.batch import sample_rng
        >>> pts = np.random.default_rng(0).random((200, 3)) * 50
        >>> bound = RandomGP(sigma=30.0, scale=1.0, n_inducing=50, rank=10).bind(pts)
        >>> bound.draw(sample_rng(0, 0), 0).deform(pts).shape
        (200, 3)
        """
        pts = np.asarray(points, dtype=np.float64)
        kernel: Kernel
        if self.kernel == "gaussian":
            kernel = GaussianKernel(sigma=self.sigma, scale=self.scale)
        else:
            kernel = BSplineKernel(Lattice.around(pts, shape=self.num_control_points), scale=self.scale)
        process = GaussianProcess(kernel)
        model = LowRankGP.nystrom(process, pts, n_inducing=self.n_inducing, rank=self.rank, rng=self.seed)
        extent = float(np.ptp(pts, axis=0).max()) or 1.0
        return BoundGP(self, model, 1e-4 * extent)


@dataclass(frozen=True)
class BoundGP:
    """A :class:`RandomGP` built on a mesh: draws :class:`GPSample` objects."""

    model: RandomGP
    process: LowRankGP
    step: float

    def draw(self, rng: np.random.Generator, index: int) -> GPSample:
        """One sample: ``rank`` standard-normal coefficients (``index`` is not used)."""
        return GPSample(self, rng.standard_normal(self.process.rank))

    def sample_from(self, coefficients: ArrayLike) -> GPSample:
        """The sample with the given coefficients (for replay)."""
        return GPSample(self, np.asarray(coefficients, dtype=np.float64))


@dataclass(frozen=True)
class GPSample:
    """One drawn displacement field: the model and its coefficients."""

    bound: BoundGP
    coefficients: NDArray[np.float64]
    scale: float = 1.0

    def _field(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        process = self.bound.process
        own = process.points
        if points is own or (points.shape == own.shape and np.array_equal(points, own)):
            return process.instance(self.coefficients)  # the model's own vertices: stored basis, no kernel evaluation
        return process.instance(self.coefficients, points)

    def deform(self, points: ArrayLike) -> NDArray[np.float64]:
        """Deformed ``(N, 3)`` points ``x + u(x)``."""
        pts = np.asarray(points, dtype=np.float64)
        return pts + self._field(pts)

    def jacobian_determinant(self, points: ArrayLike) -> NDArray[np.float64]:
        """``det(I + du/dx)`` by central differences (see :class:`RandomGP`)."""
        pts = np.asarray(points, dtype=np.float64)
        h = self.bound.step
        jac = np.empty((len(pts), 3, 3))
        for axis in range(3):
            shift = np.zeros(3)
            shift[axis] = h
            jac[:, :, axis] = (self._field(pts + shift) - self._field(pts - shift)) / (2 * h)
        jac += np.eye(3)
        return np.linalg.det(jac)

    def scaled(self, factor: float) -> GPSample:
        """The field multiplied by ``factor`` (its coefficients scaled)."""
        return GPSample(self.bound, self.coefficients * factor, self.scale * factor)
