"""An interactive explorer for Gaussian-process deformation models (beside the FFD editor).

:class:`GPExplorer` owns a PyVista plotter with a mesh, a kernel-width slider, a "sample" button,
arrows of the displacement on a grid around the mesh, and landmarks: press ``P`` over the mesh
(or right-click) to add one, drag its sphere to set the observed displacement; the mesh then shows the posterior
mean deformation, coloured by the pointwise posterior variance. Each landmark has its own
observation noise: a variance, three variances or a 3x3 covariance. Everything the widgets do is a
method too (:meth:`~GPExplorer.set_sigma`, :meth:`~GPExplorer.sample`,
:meth:`~GPExplorer.add_landmark`, :meth:`~GPExplorer.set_mode`, ...), so it works from code and headless.

For a kernel, the model is a :class:`~ffd_notebook.gp.LowRankGP` over the mesh's vertices *and*
the arrow grid, so arrows and mesh show the same random field. A shape model instead (a
Statismo ``.h5`` file or a ``LowRankGP`` from examples: ``GPExplorer(model=...)`` or
:meth:`~GPExplorer.open_model`) shows its mean shape, sliders for its first modes and the log
density of the shape shown (see :mod:`~ffd_notebook.view.gp.model_modes`). Updates write the mesh
points, colours and arrow vectors in place; no actor is re-created.
"""

from __future__ import annotations

import functools
import os
from typing import Any

import numpy as np
import pyvista as pv
import vtk
from numpy.typing import ArrayLike, NDArray

from ..._util.deprecation import renamed_keyword
from ...gp import ExponentialKernel, GaussianKernel, GaussianProcess, Kernel, LowRankGP, grid_points
from ...meshing import as_surface
from ..rendering.plotters import new_plotter
from ..serving.jupyter import forget_shown, keep_while_shown, release_views, show_changes, show_plotter
from ..serving.lifetime import Lifetime, weak_call
from .model_modes import (
    VARIANCE_ARRAY,
    ModelModes,
    landmark_covariance,
    model_mesh,
    resolve_model,
)

__all__ = ["EXPLORER_KERNELS", "VARIANCE_ARRAY", "GPExplorer"]

#: Kernel families the explorer offers: name -> class taking ``(sigma, scale)``.
EXPLORER_KERNELS = {"gaussian": GaussianKernel, "exponential": ExponentialKernel}
VECTORS_ARRAY = "gp_displacement"


class GPExplorer(ModelModes):
    """Random and conditioned deformations of a mesh from a Gaussian process, shown live.

    Parameters
    ----------
    mesh : pyvista.DataSet, optional
        The mesh to deform with a kernel model (copied; a volume mesh is replaced by its surface).
    sigma : float, optional
        Kernel width; default a quarter of the bounding-box diagonal.
    scale : float, optional
        Standard deviation of each displacement component (sets the colour range); default 3% of
        the diagonal for a kernel, the model's own for a shape model.
    kernel : {"gaussian", "exponential"}
        Kernel family (:data:`EXPLORER_KERNELS`).
    grid_shape : int or three ints
        Arrows per axis.
    n_inducing, rank : int
        Size of the Nystrom low-rank model rebuilt when ``sigma`` changes.
    noise : float, (3,) or (3, 3) array_like, optional
        Default observation noise of a landmark: variance, per-axis variances or covariance;
        default ``(0.01 * scale)^2``. Kept as ``noise``, a 3x3 covariance.
    rng : int or numpy.random.Generator
        Random source of the inducing points and of :meth:`sample` without an argument (the
        button): the same ``rng`` gives the same sequence of samples. ``seed=`` is a deprecated alias.
    plotter : pyvista.Plotter, optional
        Draw into this plotter instead of a new one.
    widgets : bool
        Add the sliders, the button, point picking and landmark spheres.
    model : LowRankGP or path, optional
        Show this shape model (a Statismo ``.h5`` file) instead of a kernel model of ``mesh``.
    n_modes : int
        Mode sliders for a shape model (at most its rank).
    **plotter_kwargs
        Passed to :class:`pyvista.Plotter` (``off_screen=True``, ``window_size=...``).

    Examples
    --------
    >>> import pyvista as pv
    >>> explorer = GPExplorer(pv.Sphere(), off_screen=True, window_size=(300, 200))
    >>> explorer.sample(rng=1)
    >>> bool(abs(explorer.mesh.points - explorer.rest_points).max() > 0)
    True
    >>> explorer.add_landmark(explorer.rest_points[0], (0.0, 0.0, 0.2))   # landmark 0
    0
    >>> explorer.displacement[0].round(2).tolist()
    [0.0, 0.0, 0.2]
    >>> explorer.set_landmark_noise(0, [1e-6, 1e-6, 1.0])   # z barely observed: back towards 0
    >>> bool(abs(explorer.displacement[0, 2]) < 0.1)
    True
    >>> explorer.close()
    """

    def __init__(
        self,
        mesh: Any = None,
        *,
        sigma: float | None = None,
        scale: float | None = None,
        kernel: str = "gaussian",
        grid_shape: int | tuple[int, int, int] = (5, 5, 5),
        n_inducing: int = 300,
        rank: int = 150,
        noise: ArrayLike | None = None,
        rng: int | np.random.Generator = 0,
        plotter: pv.Plotter | None = None,
        widgets: bool = True,
        model: LowRankGP | str | os.PathLike[str] | None = None,
        n_modes: int = 5,
        **plotter_kwargs: Any,
    ) -> None:
        if kernel not in EXPLORER_KERNELS:
            raise ValueError(f"kernel must be one of {sorted(EXPLORER_KERNELS)}, got {kernel!r}")
        if (mesh is None) == (model is None):
            raise ValueError("give either a mesh (for a kernel model) or a shape model, not both")
        self.kernel_name = kernel
        rng = renamed_keyword(plotter_kwargs, "seed", "rng", rng, "GPExplorer")
        self.n_inducing, self.rank, self.n_modes = n_inducing, rank, int(n_modes)
        self.rng = np.random.default_rng(rng)
        # the inducing points stay the same when sigma changes: a fixed seed (the int itself, as before)
        self._seed = rng if isinstance(rng, int | np.integer) else int(self.rng.integers(2**63))
        self._scale_arg, self._noise_arg = scale, noise
        self.landmarks: list[tuple[NDArray[np.float64], NDArray[np.float64]]] = []
        self.landmark_noise: list[NDArray[np.float64]] = []  # a 3x3 covariance per landmark
        self._posterior: LowRankGP | None = None
        self._coefficients: NDArray[np.float64] | None = None  # None: show the mean
        self._variance_stale = True
        self.slider: Any = None
        self.mode_sliders: list[Any] = []
        if model is not None:
            loaded, name = resolve_model(model)
            self.mesh = model_mesh(loaded)
            self.set_model(loaded, name)
        else:
            self.mesh = as_surface(mesh)
            self.model_name: str | None = None  # None: a kernel model of the mesh
            self.set_rest_points(self.mesh.points, None)
            self.sigma: float | None = float(sigma if sigma is not None else 0.25 * self.size)
            self.grid = grid_points(np.asarray(self.mesh.bounds, dtype=np.float64), grid_shape, margin=0.05)
            self.model: LowRankGP = self._build_model()
        self.plotter = plotter if plotter is not None else new_plotter(**plotter_kwargs)
        # released when the explorer is closed or collected: its browser views, and the plotter if it made it
        # (PyVista keeps every plotter until it is closed); the widgets' callbacks refer to the explorer weakly
        self.lifetime = Lifetime(self, functools.partial(release_views, self.plotter))
        if plotter is None:
            self.lifetime.add(self.plotter.close)
        self._add_actors()
        if widgets:
            self._add_widgets()
        self.refresh()

    def set_rest_points(self, points: ArrayLike, model_scale: float | None) -> None:
        """Rest shape, its size, the colour scale and the default landmark noise.

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` rest positions of the vertices.
        model_scale : float or None
            The colour scale a shape model gives (its typical displacement); None: 3 % of the shape's size
            (unless the explorer was given ``scale``).

        Examples
        --------
        >>> import pyvista as pv
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> explorer = GPExplorer(sphere, off_screen=True, window_size=(64, 48), rng=0)
        >>> explorer.set_rest_points(2 * sphere.points, None)
        >>> round(explorer.size, 3), round(explorer.scale, 4)
        (3.406, 0.1022)
        >>> explorer.close()
        """
        self.rest_points = np.array(points, dtype=np.float64)
        extent = self.rest_points.max(axis=0) - self.rest_points.min(axis=0)
        self.size = float(np.linalg.norm(extent)) or 1.0
        default = model_scale if model_scale is not None else 0.03 * self.size
        self.scale = float(self._scale_arg if self._scale_arg is not None else default) or 1.0
        noise = self._noise_arg if self._noise_arg is not None else (0.01 * self.scale) ** 2
        self.noise = landmark_covariance(noise)

    # ------------------------------------------------------------------ model
    @property
    def kernel(self) -> Kernel | None:
        """The current kernel (a new object for every width); None for a shape model."""
        if self.model_name is not None:
            return None
        assert self.sigma is not None  # a kernel model has a width
        return EXPLORER_KERNELS[self.kernel_name](sigma=self.sigma, scale=self.scale)

    @property
    def process(self) -> LowRankGP:
        """The model being shown: the posterior if there are landmarks, else the prior."""
        return self._posterior if self._posterior is not None else self.model

    @property
    def displacement(self) -> NDArray[np.float64]:
        """Displacement of each mesh vertex as shown, ``(N, 3)``."""
        return np.asarray(self.mesh.points, dtype=np.float64) - self.rest_points

    def _build_model(self) -> LowRankGP:
        points = np.vstack([self.rest_points, self.grid])
        kernel = self.kernel
        assert kernel is not None  # only kernel models are built
        gp = GaussianProcess(kernel)
        return LowRankGP.nystrom(gp, points, n_inducing=self.n_inducing, rank=self.rank, rng=self._seed)

    def _condition(self) -> None:
        self._posterior = self.conditioned(self.landmarks, self.landmark_noise)

    # ------------------------------------------------------------------ actions (also the widgets' callbacks)
    def set_sigma(self, sigma: float) -> None:
        """Change the kernel width: rebuild the model and redraw (same random coefficients).

        Parameters
        ----------
        sigma : float
            The new width (positive; a ValueError for a shape model, which has none).

        Examples
        --------
        >>> import pyvista as pv
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> explorer = GPExplorer(sphere, off_screen=True, window_size=(64, 48), rng=0)
        >>> explorer.set_sigma(0.2)
        >>> explorer.sigma, float(explorer.kernel.sigma)
        (0.2, 0.2)
        >>> explorer.close()
        """
        if self.model_name is not None:
            raise ValueError(f"{self.model_name} is a shape model: it has no kernel width")
        if not np.isfinite(sigma) or sigma <= 0:
            raise ValueError(f"sigma must be positive, got {sigma!r}")
        self.sigma = float(sigma)
        self.model = self._build_model()
        if self._coefficients is not None and len(self._coefficients) != self.model.rank:
            self._coefficients = np.random.default_rng(self._seed).standard_normal(self.model.rank)
        self._condition()
        self._variance_stale = True
        self.refresh()

    def sample(self, rng: int | np.random.Generator | None = None, *, seed: int | None = None) -> None:
        """Show a random deformation (a posterior sample when there are landmarks).

        Parameters
        ----------
        rng : int or numpy.random.Generator, optional
            Fixes the sample; without it the next draw of the explorer's own :attr:`rng`, as the
            "sample" button does.
        seed : int, optional
            Deprecated alias of ``rng``.

        Examples
        --------
        >>> import pyvista as pv
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> explorer = GPExplorer(sphere, off_screen=True, window_size=(64, 48), rng=0)
        >>> explorer.sample(rng=1)
        >>> first = explorer.displacement.copy()
        >>> explorer.sample(rng=1)
        >>> bool(abs(first).max() > 0), bool((explorer.displacement == first).all())
        (True, True)
        >>> explorer.close()
        """
        if seed is not None:
            rng = renamed_keyword({"seed": seed}, "seed", "rng", rng, "GPExplorer.sample")
        draw = self.rng if rng is None else np.random.default_rng(rng)
        self._coefficients = draw.standard_normal(self.model.rank)
        self.sync_mode_sliders()
        self.refresh()

    def show_mean(self) -> None:
        """Show the mean deformation (the posterior mean when there are landmarks).

        Examples
        --------
        >>> import pyvista as pv
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> explorer = GPExplorer(sphere, off_screen=True, window_size=(64, 48), rng=0)
        >>> explorer.sample(rng=1)
        >>> explorer.show_mean()
        >>> float(abs(explorer.displacement).max())
        0.0
        >>> explorer.close()
        """
        self._coefficients = None
        self.sync_mode_sliders()
        self.refresh()

    def add_landmark(
        self, point: ArrayLike, displacement: ArrayLike | None = None, noise: ArrayLike | None = None
    ) -> int:
        """Observe a displacement at a point (rest coordinates); returns the landmark's index.

        Without ``displacement`` the landmark pins the point where it is currently shown. The
        displacement is from the rest (reference) point, not from the mean shape. The view switches
        to the posterior mean.

        Parameters
        ----------
        point : array_like
            Where the displacement is observed (rest coordinates, 3 values).
        displacement : array_like, optional
            The observed displacement; by default the one shown there now.
        noise : float or array_like, optional
            The observation's variance, three variances or a 3x3 covariance (default: the explorer's
            ``noise``).

        Returns
        -------
        int
            The new landmark's index.

        Examples
        --------
        >>> import pyvista as pv
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> explorer = GPExplorer(sphere, off_screen=True, window_size=(64, 48), rng=0)
        >>> explorer.add_landmark(explorer.rest_points[0], (0.0, 0.0, 0.2))
        0
        >>> explorer.displacement[0].round(2).tolist()
        [0.0, 0.0, 0.2]
        >>> explorer.close()
        """
        where = np.asarray(point, dtype=np.float64).reshape(3)
        if displacement is None:
            moved = self.process.mean(where[None])[0] if self._coefficients is None else self._shown_at(where)
        else:
            moved = np.asarray(displacement, dtype=np.float64).reshape(3)
        cov = self.noise if noise is None else landmark_covariance(noise)
        landmarks, covs = [*self.landmarks, (where, moved)], [*self.landmark_noise, cov]
        self._posterior = self.conditioned(landmarks, covs)  # may raise: nothing changed yet
        self.landmarks[:], self.landmark_noise[:] = landmarks, covs
        self._coefficients = None
        self.sync_mode_sliders()
        self._variance_stale = True
        if self._widgets_on:
            self._add_landmark_widget(len(self.landmarks) - 1)
        self.refresh()
        return len(self.landmarks) - 1

    def move_landmark(self, index: int, displacement: ArrayLike) -> None:
        """Set the observed displacement of landmark ``index`` (the posterior variance is unchanged).

        Parameters
        ----------
        index : int
            The landmark (as :meth:`add_landmark` returned it).
        displacement : array_like
            Its new observed displacement.

        Examples
        --------
        >>> import pyvista as pv
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> explorer = GPExplorer(sphere, off_screen=True, window_size=(64, 48), rng=0)
        >>> explorer.add_landmark(explorer.rest_points[0], (0.0, 0.0, 0.2))
        0
        >>> explorer.move_landmark(0, (0.0, 0.1, 0.0))
        >>> explorer.displacement[0].round(2).tolist()
        [0.0, 0.1, 0.0]
        >>> explorer.close()
        """
        where, _ = self.landmarks[index]
        self.landmarks[index] = (where, np.asarray(displacement, dtype=np.float64).reshape(3))
        self._condition()
        self.refresh()

    def clear_landmarks(self) -> None:
        """Remove every landmark: back to the prior.

        Examples
        --------
        >>> import pyvista as pv
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> explorer = GPExplorer(sphere, off_screen=True, window_size=(64, 48), rng=0)
        >>> explorer.add_landmark(explorer.rest_points[0], (0.0, 0.0, 0.2))
        0
        >>> explorer.clear_landmarks()
        >>> len(explorer.landmarks), float(abs(explorer.displacement).max())
        (0, 0.0)
        >>> explorer.close()
        """
        self.landmarks.clear()
        self.landmark_noise.clear()
        if self._widgets_on:
            self.plotter.clear_sphere_widgets()
        self._condition()
        self._variance_stale = True
        self.refresh()

    def screenshot(self, filename: str | None = None) -> NDArray[np.uint8]:
        """Render and return the image (and write it if ``filename`` is given).

        Parameters
        ----------
        filename : str, optional
            An image file to write too (PNG, JPEG... by extension).

        Returns
        -------
        numpy.ndarray
            The rendered view, ``(height, width, 3)`` uint8.

        Examples
        --------
        >>> import pyvista as pv
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> explorer = GPExplorer(sphere, off_screen=True, window_size=(64, 48), rng=0)
        >>> image = explorer.screenshot()
        >>> image.shape, image.dtype.name
        ((48, 64, 3), 'uint8')
        >>> explorer.close()
        """
        self.plotter.render()
        return self.plotter.screenshot(filename, return_img=True)

    def show(self, **kwargs: Any) -> Any:
        """Show the explorer: in Jupyter the server-rendered trame view its widgets need.

        See :func:`ffd_notebook.view.serving.jupyter.show_plotter`; outside a kernel, ``plotter.show(**kwargs)``.
        The output showing it keeps the explorer alive until its cell runs again
        (:func:`~ffd_notebook.view.serving.jupyter.keep_while_shown`).

        Parameters
        ----------
        **kwargs
            Passed to ``plotter.show`` outside a kernel (or with a static backend).

        Returns
        -------
        object
            In a kernel, the trame view's widget; elsewhere what ``plotter.show`` returns (None, or the
            picture with ``return_img=True``).

        Examples
        --------
        Outside a kernel (a script, a test), the picture PyVista renders:

        >>> import pyvista as pv
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> explorer = GPExplorer(sphere, off_screen=True, window_size=(64, 48), rng=0)
        >>> explorer.show(return_img=True, auto_close=False).shape
        (48, 64, 3)
        >>> explorer.close()
        """
        shown = show_plotter(self.plotter, **kwargs)
        keep_while_shown(self)
        return shown

    def close(self) -> None:
        """Close the browser views and the plotter (if the explorer made it) and free its render window.

        An explorer nobody refers to any more (no variable, no output showing it) is closed the same way.

        Examples
        --------
        >>> import pyvista as pv
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> explorer = GPExplorer(sphere, off_screen=True, window_size=(64, 48), rng=0)
        >>> explorer.close()
        >>> explorer.lifetime.alive
        False
        """
        forget_shown(self)
        self.lifetime.close()

    # ------------------------------------------------------------------ drawing
    def _shown_at(self, point: NDArray[np.float64]) -> NDArray[np.float64]:
        assert self._coefficients is not None  # the mean is shown without coefficients
        return self.process.instance(self._coefficients, point[None])[0]

    def _add_actors(self) -> None:
        pl = self.plotter
        self.mesh.point_data[VARIANCE_ARRAY] = np.zeros(self.mesh.n_points)
        self.mesh_actor = pl.add_mesh(
            self.mesh,
            scalars=VARIANCE_ARRAY,
            cmap="viridis",
            clim=(0.0, 3.0 * self.scale**2),
            scalar_bar_args={
                "title": "variance",
                "vertical": True,
                "position_x": 0.86,
                "position_y": 0.3,
                "height": 0.5,
                "width": 0.06,
            },
            smooth_shading=True,
        )
        self.arrow_points: pv.PolyData | None = None
        self.arrow_actor: Any = None
        if len(self.grid):  # a kernel model: arrows of the same field on a grid around the mesh
            self._add_arrows()
        self._status = pl.add_text("", position="upper_left", font_size=9)

    def _add_arrows(self) -> None:
        self.arrow_points = pv.PolyData(self.grid.copy())
        self.arrow_points.point_data.set_vectors(np.zeros_like(self.grid), VECTORS_ARRAY)
        glyphs = vtk.vtkGlyph3D()
        glyphs.SetInputData(self.arrow_points)
        glyphs.SetSourceData(pv.Arrow())
        glyphs.SetVectorModeToUseVector()
        glyphs.SetScaleModeToScaleByVector()  # arrows at true length: where each grid point goes
        glyphs.OrientOn()
        self._glyphs = glyphs
        self.arrow_actor = self.plotter.add_mesh(glyphs, color="tomato", pickable=False)

    def _add_widgets(self) -> None:
        pl = self.plotter
        if self.model_name is None:
            self.slider = pl.add_slider_widget(
                weak_call(self, lambda self, value: self.guarded(self._on_width, value)),
                rng=(0.02 * self.size, self.size),
                value=self.sigma,
                title="kernel width sigma",
                pointa=(0.55, 0.12),
                pointb=(0.95, 0.12),
                style="modern",
                fmt="%.3g",
            )
        else:
            self.add_mode_sliders()
        # a checkbox used as a push button: every click draws a new sample
        self.button = pl.add_checkbox_button_widget(
            weak_call(self, lambda self, _: self.guarded(self.sample)), position=(10, 10), size=30
        )
        pl.add_text("sample", position=(48, 14), font_size=10)
        pl.enable_point_picking(
            callback=weak_call(self, lambda self, point, picker: self.guarded(self._on_pick, picker)),
            use_picker=True,
            show_message=False,
            show_point=False,
        )
        self._widgets_on = True
        self.sync_mode_sliders()

    _widgets_on = False

    def _on_width(self, value: float) -> None:
        if value != self.sigma:  # a slider reports its value when it is created: no rebuild then
            self.set_sigma(value)

    def _on_pick(self, picker: Any) -> None:
        vertex = int(picker.GetPointId())
        if picker.GetActor() is not self.mesh_actor or not 0 <= vertex < self.mesh.n_points:
            return  # not the mesh: a landmark's sphere, the arrows or nothing
        self.add_landmark(self.rest_points[vertex])

    def _add_landmark_widget(self, index: int) -> None:
        where, moved = self.landmarks[index]

        def dragged(self: GPExplorer, center: Any) -> None:
            self.guarded(self.move_landmark, index, np.asarray(center) - where)

        self.plotter.add_sphere_widget(
            weak_call(self, dragged),
            center=where + moved,
            radius=0.015 * self.size,
            color="orange",
            test_callback=False,
            interaction_event="always",
        )

    def refresh(self) -> None:
        """Show the current deformation: mesh points, arrows and variance, in place.

        Examples
        --------
        The mesh shown is redrawn from the model, whatever was done to its points:

        >>> import pyvista as pv
        >>> sphere = pv.Sphere(theta_resolution=8, phi_resolution=8)
        >>> explorer = GPExplorer(sphere, off_screen=True, window_size=(64, 48), rng=0)
        >>> explorer.sample(rng=1)
        >>> shown = explorer.mesh.points.copy()
        >>> explorer.mesh.points[:] = 0.0
        >>> explorer.refresh()
        >>> bool((explorer.mesh.points == shown).all())
        True
        >>> explorer.close()
        """
        process = self.process
        field = process.mean() if self._coefficients is None else process.instance(self._coefficients)
        n = len(self.rest_points)
        self.mesh.points[...] = self.rest_points + field[:n]
        if self.arrow_points is not None and len(self.grid):
            self.arrow_points.point_data[VECTORS_ARRAY][...] = field[n:]
            self.arrow_points.Modified()
        if self._variance_stale:
            self.mesh.point_data[VARIANCE_ARRAY][...] = process.variance()[:n].sum(axis=1)
            self._variance_stale = False
        self.log_density = self.model.logpdf_of(field)  # under the prior: how plausible the shape is
        self._status.SetText(2, self.status_text())
        show_changes(self.plotter)  # a change made from code reaches an open notebook view too
