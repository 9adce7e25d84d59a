"""The model-file half of :class:`~ffd_notebook.view.gp.explorer.GPExplorer`: shape models and their modes.

A shape model (a Statismo/Scalismo ``.h5`` file read by :func:`~ffd_notebook.gp.load_model`, or
a :class:`~ffd_notebook.gp.LowRankGP` such as one built by ``LowRankGP.from_examples``) is shown
as its mean shape ``model.points + model.mean()``; its first principal modes get sliders in
standard-normal units. :class:`ModelModes` holds these methods; ``GPExplorer`` derives from it
(as ``LowRankGP`` derives from its builders), so this module keeps the model-file parts apart.
The functions here turn a model into a mesh and per-landmark noise into 3x3 covariances.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pyvista as pv
from numpy.typing import ArrayLike, NDArray

from ...gp import LowRankGP, load_model
from ...gp.noise import observation_noise
from ..serving.lifetime import weak_call

__all__ = [
    "MODE_RANGE",
    "VARIANCE_ARRAY",
    "ModelModes",
    "landmark_covariance",
    "model_mesh",
    "resolve_model",
    "stacked_noise",
]

#: Point data array of the mesh holding the pointwise (posterior) variance, summed over x, y, z.
VARIANCE_ARRAY = "gp_variance"
#: Slider range of a mode's coefficient (standard deviations).
MODE_RANGE = (-3.0, 3.0)


log = logging.getLogger(__name__)


def resolve_model(source: LowRankGP | str | os.PathLike[str]) -> tuple[LowRankGP, str]:
    """The model and a name to show for it: a :class:`~ffd_notebook.gp.LowRankGP` or a Statismo file.

    A bad file raises :class:`~ffd_notebook.errors.FileFormatError` (from
    :func:`~ffd_notebook.gp.load_model`) before anything is changed.

    Examples
    --------
    >>> import numpy as np
    >>> ref = np.random.default_rng(0).random((10, 3))
    >>> model, name = resolve_model(LowRankGP.from_examples(ref, [ref, ref + 0.1]))
    >>> name
    'model (10 points, rank 1)'
    """
    if isinstance(source, LowRankGP):
        return source, f"model ({len(source.points)} points, rank {source.rank})"
    if isinstance(source, str | os.PathLike):
        return load_model(source), Path(source).name
    raise TypeError(f"expected a LowRankGP or the path of a Statismo .h5 file, got {type(source).__name__}")


def model_mesh(model: LowRankGP) -> pv.PolyData:
    """The model's mean shape as a surface (its triangles) or, without triangles, as a point cloud.

    Examples
    --------
    >>> import numpy as np
    >>> ref = np.random.default_rng(0).random((10, 3))
    >>> model_mesh(LowRankGP.from_examples(ref, [ref, ref + 0.1])).n_verts
    10
    """
    points = model.points + model.mean()
    cells = model.cells
    if cells is None or len(cells) == 0:
        return pv.PolyData(points)  # PyVista gives each point a vertex cell, so it is drawn
    return pv.PolyData.from_regular_faces(points, np.asarray(cells, dtype=np.int64))


def landmark_covariance(noise: ArrayLike) -> NDArray[np.float64]:
    """One landmark's noise as a 3x3 covariance: a variance, three variances or a 3x3 covariance.

    Validated by the model's own parser (:func:`~ffd_notebook.gp.noise.observation_noise`).

    Examples
    --------
    >>> landmark_covariance(0.5).tolist()
    [[0.5, 0.0, 0.0], [0.0, 0.5, 0.0], [0.0, 0.0, 0.5]]
    >>> landmark_covariance([1.0, 2.0, 3.0]).diagonal().tolist()
    [1.0, 2.0, 3.0]
    """
    arr = np.asarray(noise, dtype=np.float64)
    if arr.shape not in ((), (3,), (3, 3)):
        raise ValueError(f"a landmark's noise is a variance, 3 variances or a 3x3 covariance, got shape {arr.shape}")
    return observation_noise(arr[None], 1).covariances[0].copy()


def stacked_noise(covariances: list[NDArray[np.float64]]) -> NDArray[np.float64]:
    """Noise for ``posterior``: ``(L, 3)`` variances when every covariance is diagonal, else ``(L, 3, 3)``.

    Variances let a kernel model solve each component on its own (see
    :mod:`~ffd_notebook.gp.lowrank_ops`).

    Examples
    --------
    >>> import numpy as np
    >>> stacked_noise([np.eye(3), 2 * np.eye(3)]).tolist()
    [[1.0, 1.0, 1.0], [2.0, 2.0, 2.0]]
    >>> stacked_noise([np.eye(3), np.ones((3, 3)) + np.eye(3)]).shape
    (2, 3, 3)
    """
    covs = np.stack(covariances)
    diagonal = covs.diagonal(axis1=1, axis2=2)
    if np.array_equal(covs, np.einsum("la,ab->lab", diagonal, np.eye(3))):
        return diagonal.copy()
    return covs


class ModelModes:
    """Opening shape models, moving along their modes, landmark noise (mixed into ``GPExplorer``).

    Uses ``GPExplorer``'s state and its ``process``, ``set_rest_points`` and ``refresh``.

    Examples
    --------
    A shape model built from examples, moved along its first mode:

    >>> import pyvista as pv
    >>> from ffd_notebook.view import GPExplorer
    >>> ref = pv.Sphere()
    >>> model = LowRankGP.from_examples(ref, [ref.points * s for s in (0.9, 1.0, 1.1)])
    >>> explorer = GPExplorer(model=model, off_screen=True, window_size=(300, 200))
    >>> explorer.set_mode(0, 1.0)
    >>> bool(np.allclose(explorer.displacement, model.instance([1.0]), atol=1e-6))
    True
    >>> explorer.close()
    """

    plotter: pv.Plotter
    mesh: pv.PolyData
    model: LowRankGP
    n_modes: int
    mode_sliders: list[Any]
    _coefficients: NDArray[np.float64] | None
    _widgets_on: bool
    kernel_name: str
    sigma: float | None
    log_density: float
    # set or defined by the class that mixes these in (GPExplorer)
    model_name: str | None
    landmarks: list[tuple[NDArray[np.float64], NDArray[np.float64]]]
    landmark_noise: list[NDArray[np.float64]]
    scale: float
    mesh_actor: Any
    arrow_actor: Any
    slider: Any

    if TYPE_CHECKING:

        @property
        def process(self) -> LowRankGP: ...

        def refresh(self) -> None: ...

        def set_rest_points(self, points: ArrayLike, model_scale: float | None) -> None: ...

    @staticmethod
    def guarded(fn: Any, *args: Any) -> None:
        """Run a widget callback ``fn(*args)``; a failure is logged, not lost in a PyVista warning.

        Parameters
        ----------
        fn : callable
            The callback.
        *args
            Its arguments.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import GPExplorer
        >>> ref = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> model = LowRankGP.from_examples(ref, [ref.points * s for s in (0.9, 1.0, 1.1)])
        >>> explorer = GPExplorer(model=model, off_screen=True, window_size=(64, 48))
        >>> explorer.guarded(explorer.set_mode, 0, 0.5)
        >>> explorer.coefficients.tolist()
        [0.5]
        >>> explorer.guarded(explorer.set_mode, 9, 0.5)
        Traceback (most recent call last):
        ...
        IndexError: mode 9 out of range for rank 1
        >>> explorer.close()
        """
        # PyVista turns exceptions in callbacks into warnings: log them where they can be read
        try:
            fn(*args)
        except Exception:
            log.exception("GPExplorer callback failed")
            raise

    def open_model(self, source: LowRankGP | str | os.PathLike[str]) -> None:
        """Show a shape model: a Statismo ``.h5`` file or a :class:`~ffd_notebook.gp.LowRankGP`.

        The mesh becomes the model's mean shape, landmarks are dropped, and the first
        :attr:`n_modes` modes get sliders. A file that cannot be read raises
        :class:`~ffd_notebook.errors.FileFormatError` and leaves the explorer as it was.

        Parameters
        ----------
        source : LowRankGP or str or os.PathLike
            The model, or its Statismo file.

        Examples
        --------
        A kernel model of a sphere, then a shape model of spheres of three sizes:

        >>> import pyvista as pv
        >>> from ffd_notebook.view import GPExplorer
        >>> ref = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> explorer = GPExplorer(ref, off_screen=True, window_size=(64, 48), rng=0)
        >>> explorer.open_model(LowRankGP.from_examples(ref, [ref.points * s for s in (0.9, 1.0, 1.1)]))
        >>> print(explorer.status_text().splitlines()[0])
        model (50 points, rank 1), rank 1: prior mean
        >>> explorer.close()
        """
        model, name = resolve_model(source)  # every failure happens here, before any change
        self._use_model(model, name, model_mesh(model))

    def set_landmark_noise(self, index: int, noise: ArrayLike) -> None:
        """Change landmark ``index``'s noise: a variance, three variances or a 3x3 covariance.

        Parameters
        ----------
        index : int
            The landmark.
        noise : float or array_like
            Its observation's variance, three variances (x, y, z) or a 3x3 covariance.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import GPExplorer
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> explorer = GPExplorer(sphere, off_screen=True, window_size=(64, 48), rng=0)
        >>> explorer.add_landmark(explorer.rest_points[0], (0.0, 0.0, 0.2))
        0
        >>> explorer.set_landmark_noise(0, [1e-6, 1e-6, 1.0])  # z barely observed: back towards 0
        >>> bool(abs(explorer.displacement[0, 2]) < 0.1)
        True
        >>> explorer.close()
        """
        covs = list(self.landmark_noise)
        covs[index] = landmark_covariance(noise)
        self._posterior = self.conditioned(self.landmarks, covs)
        self.landmark_noise[:] = covs
        self._variance_stale = True
        self.refresh()

    def conditioned(
        self, landmarks: list[tuple[NDArray, NDArray]], noise: list[NDArray[np.float64]]
    ) -> LowRankGP | None:
        """The model conditioned on landmarks (the posterior), or None without landmarks.

        Parameters
        ----------
        landmarks : list of tuple of numpy.ndarray
            ``(point, displacement)`` pairs, rest coordinates.
        noise : list of numpy.ndarray
            One 3x3 observation covariance per landmark.

        Returns
        -------
        LowRankGP or None
            The posterior; None if ``landmarks`` is empty. The explorer does not change.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import GPExplorer
        >>> ref = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> model = LowRankGP.from_examples(ref, [ref.points * s for s in (0.9, 1.0, 1.1)])
        >>> explorer = GPExplorer(model=model, off_screen=True, window_size=(64, 48))
        >>> point = explorer.rest_points[:1]
        >>> posterior = explorer.conditioned([(point[0], np.array([0.0, 0.0, 0.2]))], [1e-6 * np.eye(3)])
        >>> posterior.mean(point).round(2).tolist(), explorer.conditioned([], []) is None
        ([[0.0, 0.0, 0.2]], True)
        >>> explorer.close()
        """
        if not landmarks:
            return None
        where, moved = (np.array(v) for v in zip(*landmarks, strict=True))
        return self.model.posterior(where, moved, stacked_noise(noise))

    def set_model(self, model: LowRankGP, name: str) -> None:
        """Make a shape model the one shown (no drawing).

        Landmarks are dropped and the mean is shown at the next ``refresh()``; the mesh keeps its cells
        (:meth:`open_model` also replaces the mesh and the sliders).

        Parameters
        ----------
        model : LowRankGP
            The shape model, on the explorer's vertices.
        name : str
            Its name in the status text.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import GPExplorer
        >>> ref = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> model = LowRankGP.from_examples(ref, [ref.points * s for s in (0.9, 1.0, 1.1)])
        >>> explorer = GPExplorer(model=model, off_screen=True, window_size=(64, 48))
        >>> explorer.set_mode(0, 1.0)
        >>> explorer.set_model(model, "spheres")
        >>> explorer.model_name, explorer.coefficients.tolist()
        ('spheres', [0.0])
        >>> explorer.close()
        """
        self.model, self.model_name, self.sigma = model, name, None
        typical = float(np.sqrt(model.variance().mean()))  # a typical displacement standard deviation
        self.set_rest_points(model.points, typical)
        self.grid = np.empty((0, 3))  # a shape model lives on its vertices: no arrows
        self.landmarks.clear()
        self.landmark_noise.clear()
        self._posterior, self._coefficients, self._variance_stale = None, None, True

    def _use_model(self, model: LowRankGP, name: str, mesh: pv.PolyData) -> None:
        """Switch to a loaded shape model: same PolyData and actors, new points, cells and widgets."""
        self.set_model(model, name)
        self.mesh.copy_from(mesh, deep=True)
        self.mesh.point_data[VARIANCE_ARRAY] = np.zeros(self.mesh.n_points)
        self.mesh.set_active_scalars(VARIANCE_ARRAY)
        self.mesh_actor.mapper.scalar_range = (0.0, 3.0 * self.scale**2)
        if self.arrow_actor is not None:
            self.arrow_actor.visibility = False
        if self._widgets_on:
            self.plotter.clear_sphere_widgets()
            if self.slider is not None:
                self.slider.Off()  # the kernel width means nothing for a shape model
            self.add_mode_sliders()
        self.plotter.reset_camera()
        self.refresh()

    @property
    def coefficients(self) -> NDArray[np.float64]:
        """The coefficients shown, ``(rank,)`` (zeros for the mean); of the posterior's modes with landmarks."""
        rank = self.process.rank
        return np.zeros(rank) if self._coefficients is None else self._coefficients.copy()

    def set_coefficients(self, coefficients: ArrayLike) -> None:
        """Show the instance with these coefficients ``(rank,)`` (standard-normal units).

        With landmarks they are coefficients of the posterior's principal modes.

        Parameters
        ----------
        coefficients : array_like
            One finite value per mode of the process shown (a ValueError otherwise).

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import GPExplorer
        >>> ref = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> model = LowRankGP.from_examples(ref, [ref.points * s for s in (0.9, 1.0, 1.1)])
        >>> explorer = GPExplorer(model=model, off_screen=True, window_size=(64, 48))
        >>> explorer.set_coefficients([0.5])
        >>> bool(np.allclose(explorer.displacement, model.instance([0.5]), atol=1e-6))
        True
        >>> explorer.mode_sliders[0].GetRepresentation().GetValue()
        0.5
        >>> explorer.close()
        """
        rank = self.process.rank
        coef = np.asarray(coefficients, dtype=np.float64)
        if coef.shape != (rank,) or not np.all(np.isfinite(coef)):
            raise ValueError(f"expected {rank} finite coefficients, got shape {coef.shape}")
        self._coefficients = coef.copy()
        self.sync_mode_sliders()
        self.refresh()

    def set_mode(self, k: int, value: float) -> None:
        """Set the coefficient of mode ``k`` (what mode slider ``k`` does); the others stay.

        Parameters
        ----------
        k : int
            The mode (0 is the first); an IndexError beyond the rank.
        value : float
            Its coefficient (standard-normal units).

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import GPExplorer
        >>> ref = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> model = LowRankGP.from_examples(ref, [ref.points * s for s in (0.9, 1.0, 1.1)])
        >>> explorer = GPExplorer(model=model, off_screen=True, window_size=(64, 48))
        >>> explorer.set_mode(0, 1.0)
        >>> explorer.coefficients.tolist()
        [1.0]
        >>> explorer.close()
        """
        coef = self.coefficients
        if not 0 <= k < len(coef):
            raise IndexError(f"mode {k} out of range for rank {len(coef)}")
        if coef[k] == value:
            return  # unchanged (a slider reports its value when it is created)
        coef[k] = value
        self.set_coefficients(coef)

    def add_mode_sliders(self) -> None:
        """Sliders for the first :attr:`n_modes` modes (more are added if a later model has more).

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import GPExplorer
        >>> ref = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> model = LowRankGP.from_examples(ref, [ref.points * s for s in (0.9, 1.0, 1.1)])
        >>> explorer = GPExplorer(model=model, off_screen=True, window_size=(64, 48))
        >>> explorer.add_mode_sliders()  # already there: nothing is added twice
        >>> len(explorer.mode_sliders)
        1
        >>> explorer.close()
        """
        wanted = min(self.n_modes, self.model.rank)
        for k in range(len(self.mode_sliders), wanted):
            x = 0.2 + 0.155 * k  # a row along the bottom, right of the "sample" button
            slider = self.plotter.add_slider_widget(
                weak_call(self, lambda self, value, k=k: self.guarded(self.set_mode, k, value)),
                rng=MODE_RANGE,
                value=0.0,
                title=f"mode {k + 1}",
                pointa=(x, 0.1),
                pointb=(x + 0.12, 0.1),
                style="modern",
                fmt="%.1f",
                title_height=0.025,
                slider_width=0.02,
                tube_width=0.004,
                interaction_event="always",
            )
            self.mode_sliders.append(slider)
        for k, slider in enumerate(self.mode_sliders):
            slider.SetEnabled(k < wanted)
        self.sync_mode_sliders()

    def status_text(self) -> str:
        """The text in the corner: the model, what is shown, its log density and how to add landmarks.

        Returns
        -------
        str
            Several lines, as shown in the view's corner.

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import GPExplorer
        >>> ref = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> model = LowRankGP.from_examples(ref, [ref.points * s for s in (0.9, 1.0, 1.1)])
        >>> explorer = GPExplorer(model=model, off_screen=True, window_size=(64, 48))
        >>> explorer.set_mode(0, 1.0)
        >>> print(explorer.status_text())
        model (50 points, rank 1), rank 1: prior instance
        log p(shape) = -0.4
        sliders: modes 1-1; right-click or P over the mesh: add a landmark; drag its sphere to move it
        >>> explorer.close()
        """
        what = "mean" if self._coefficients is None else "sample" if self.model_name is None else "instance"
        shown = f"posterior {what}, {len(self.landmarks)} landmarks" if self.landmarks else f"prior {what}"
        if self.model_name is None:
            status = f"{self.kernel_name} kernel, sigma = {self.sigma:.3g}, rank {self.process.rank}: {shown}"
        else:
            status = f"{self.model_name}, rank {self.process.rank}: {shown}"
        status += f"\nlog p(shape) = {self.log_density:.1f}"
        if self._widgets_on:
            modes = f"sliders: modes 1-{len(self.mode_sliders)}; " if self.model_name is not None else ""
            status += f"\n{modes}right-click or P over the mesh: add a landmark; drag its sphere to move it"
        return status

    def sync_mode_sliders(self) -> None:
        """Put the sliders where the coefficients are (setting a value does not call back).

        Examples
        --------
        >>> import pyvista as pv
        >>> from ffd_notebook.view import GPExplorer
        >>> ref = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> model = LowRankGP.from_examples(ref, [ref.points * s for s in (0.9, 1.0, 1.1)])
        >>> explorer = GPExplorer(model=model, off_screen=True, window_size=(64, 48))
        >>> explorer.set_mode(0, 1.0)
        >>> explorer.set_model(model, "spheres")  # the mean again, without drawing: the slider stays
        >>> explorer.mode_sliders[0].GetRepresentation().GetValue()
        1.0
        >>> explorer.sync_mode_sliders()
        >>> explorer.mode_sliders[0].GetRepresentation().GetValue()
        0.0
        >>> explorer.close()
        """
        coef = self.coefficients
        for k, slider in enumerate(self.mode_sliders):
            value = float(np.clip(coef[k], *MODE_RANGE)) if k < len(coef) else 0.0
            slider.GetRepresentation().SetValue(value)
