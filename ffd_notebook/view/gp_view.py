"""An interactive explorer for Gaussian-process deformation models (beside the FFD editor).

:class:`GPExplorer` owns a PyVista plotter with a mesh, a kernel-width slider, a "sample" button,
arrows of the displacement on a grid around the mesh, and landmarks: press ``P`` over the mesh
(or right-click) to add one, drag its sphere to set the observed displacement; the mesh then shows the posterior
mean deformation, coloured by the pointwise posterior variance. Everything the widgets do is a
method too (:meth:`~GPExplorer.set_sigma`, :meth:`~GPExplorer.sample`,
:meth:`~GPExplorer.add_landmark`, ...), so it works from code and headless.

The model is a :class:`~ffd_notebook.gp.LowRankGP` over the mesh's vertices *and* the arrow grid,
so arrows and mesh show the same random field. Updates write the mesh points, colours and arrow
vectors in place; no actor is re-created.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np
import pyvista as pv
import vtk
from numpy.typing import ArrayLike, NDArray

from ..gp import ExponentialKernel, GaussianKernel, GaussianProcess, Kernel, LowRankGP, grid_points
from . import configure_rendering
from .editor_files import as_surface
from .notebook import push_to_browser, show_plotter

__all__ = ["KERNELS", "GPExplorer"]

configure_rendering()
log = logging.getLogger(__name__)

#: Kernel families the explorer offers: name -> class taking ``(sigma, scale)``.
KERNELS = {"gaussian": GaussianKernel, "exponential": ExponentialKernel}
VARIANCE_ARRAY = "gp_variance"
VECTORS_ARRAY = "gp_displacement"


class GPExplorer:
    """Random and conditioned deformations of a mesh from a Gaussian process, shown live.

    Parameters
    ----------
    mesh : pyvista.DataSet
        The mesh to deform (copied; a volume mesh is replaced by its surface).
    sigma : float, optional
        Kernel width; default a quarter of the bounding-box diagonal.
    scale : float, optional
        Standard deviation of each displacement component; default 3% of the diagonal.
    kernel : {"gaussian", "exponential"}
        Kernel family (:data:`KERNELS`).
    grid_shape : int or three ints
        Arrows per axis.
    n_inducing, rank : int
        Size of the Nystrom low-rank model rebuilt when ``sigma`` changes.
    noise : float, optional
        Landmark observation noise variance; default ``(0.01 * scale)^2``.
    seed : int
        Seeds the inducing points and the first sample.
    plotter : pyvista.Plotter, optional
        Draw into this plotter instead of a new one.
    widgets : bool
        Add the slider, the button, point picking and landmark spheres.
    **plotter_kwargs
        Passed to :class:`pyvista.Plotter` (``off_screen=True``, ``window_size=...``).

    Examples
    --------
    >>> import pyvista as pv
    >>> explorer = GPExplorer(pv.Sphere(), off_screen=True, window_size=(300, 200))
    >>> explorer.sample(seed=1)
    >>> bool(abs(explorer.mesh.points - explorer.rest_points).max() > 0)
    True
    >>> explorer.add_landmark(explorer.rest_points[0], (0.0, 0.0, 0.2))   # landmark 0
    0
    >>> explorer.displacement[0].round(2).tolist()
    [0.0, 0.0, 0.2]
    >>> explorer.close()
    """

    def __init__(
        self,
        mesh: Any,
        sigma: float | None = None,
        scale: float | None = None,
        kernel: str = "gaussian",
        grid_shape: int | tuple[int, int, int] = (5, 5, 5),
        n_inducing: int = 300,
        rank: int = 150,
        noise: float | None = None,
        seed: int = 0,
        plotter: pv.Plotter | None = None,
        widgets: bool = True,
        **plotter_kwargs: Any,
    ) -> None:
        if kernel not in KERNELS:
            raise ValueError(f"kernel must be one of {sorted(KERNELS)}, got {kernel!r}")
        self.mesh = as_surface(mesh)
        self.rest_points = np.array(self.mesh.points, dtype=np.float64)
        bounds = np.asarray(self.mesh.bounds, dtype=np.float64)
        self.size = float(np.linalg.norm(bounds[1::2] - bounds[::2])) or 1.0
        self.sigma = float(sigma if sigma is not None else 0.25 * self.size)
        self.scale = float(scale if scale is not None else 0.03 * self.size)
        self.kernel_name = kernel
        self.noise = float(noise if noise is not None else (0.01 * self.scale) ** 2)
        self.n_inducing, self.rank, self._seed = n_inducing, rank, seed
        self.grid = grid_points(bounds, grid_shape, margin=0.05)
        self.landmarks: list[tuple[NDArray[np.float64], NDArray[np.float64]]] = []
        self.model: LowRankGP = self._build_model()
        self._posterior: LowRankGP | None = None
        self._coefficients: NDArray[np.float64] | None = None  # None: show the mean
        self._variance_stale = True
        self.plotter = plotter if plotter is not None else pv.Plotter(**plotter_kwargs)
        self._add_actors()
        if widgets:
            self._add_widgets()
        self._refresh()

    # ------------------------------------------------------------------ model
    @property
    def kernel(self) -> Kernel:
        """The current kernel (a new object for every width)."""
        return KERNELS[self.kernel_name](sigma=self.sigma, scale=self.scale)

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
        gp = GaussianProcess(self.kernel)
        return LowRankGP.nystrom(gp, points, n_inducing=self.n_inducing, rank=self.rank, rng=self._seed)

    def _condition(self) -> None:
        if not self.landmarks:
            self._posterior = None
        else:
            where, moved = (np.array(v) for v in zip(*self.landmarks, strict=True))
            self._posterior = self.model.posterior(where, moved, self.noise)

    # ------------------------------------------------------------------ actions (also the widgets' callbacks)
    def set_sigma(self, sigma: float) -> None:
        """Change the kernel width: rebuild the model and redraw (same random coefficients)."""
        if not np.isfinite(sigma) or sigma <= 0:
            raise ValueError(f"sigma must be positive, got {sigma!r}")
        self.sigma = float(sigma)
        self.model = self._build_model()
        if self._coefficients is not None and len(self._coefficients) != self.model.rank:
            self._coefficients = np.random.default_rng(self._seed).standard_normal(self.model.rank)
        self._condition()
        self._variance_stale = True
        self._refresh()

    def sample(self, seed: int | None = None) -> None:
        """Show a random deformation (a posterior sample when there are landmarks)."""
        rng = np.random.default_rng(seed)
        self._coefficients = rng.standard_normal(self.model.rank)
        self._refresh()

    def show_mean(self) -> None:
        """Show the mean deformation (the posterior mean when there are landmarks)."""
        self._coefficients = None
        self._refresh()

    def add_landmark(self, point: ArrayLike, displacement: ArrayLike | None = None) -> int:
        """Observe a displacement at a point (rest coordinates); returns the landmark's index.

        Without ``displacement`` the landmark pins the point where it is currently shown. The
        view switches to the posterior mean.
        """
        where = np.asarray(point, dtype=np.float64).reshape(3)
        if displacement is None:
            moved = self.process.mean(where[None])[0] if self._coefficients is None else self._shown_at(where)
        else:
            moved = np.asarray(displacement, dtype=np.float64).reshape(3)
        self.landmarks.append((where, moved))
        self._coefficients = None
        self._condition()
        self._variance_stale = True
        if self._widgets_on:
            self._add_landmark_widget(len(self.landmarks) - 1)
        self._refresh()
        return len(self.landmarks) - 1

    def move_landmark(self, index: int, displacement: ArrayLike) -> None:
        """Set the observed displacement of landmark ``index`` (the posterior variance is unchanged)."""
        where, _ = self.landmarks[index]
        self.landmarks[index] = (where, np.asarray(displacement, dtype=np.float64).reshape(3))
        self._condition()
        self._refresh()

    def clear_landmarks(self) -> None:
        """Remove every landmark: back to the prior."""
        self.landmarks.clear()
        if self._widgets_on:
            self.plotter.clear_sphere_widgets()
        self._condition()
        self._variance_stale = True
        self._refresh()

    def screenshot(self, filename: str | None = None) -> NDArray[np.uint8]:
        """Render and return the image (and write it if ``filename`` is given)."""
        self.plotter.render()
        return self.plotter.screenshot(filename, return_img=True)

    def show(self, **kwargs: Any) -> Any:
        """Show the explorer: in Jupyter the server-rendered trame view its widgets need.

        See :func:`ffd_notebook.view.notebook.show_plotter`; outside a kernel, ``plotter.show(**kwargs)``.
        """
        return show_plotter(self.plotter, **kwargs)

    def close(self) -> None:
        """Close the plotter and free its render window."""
        self.plotter.close()

    # ------------------------------------------------------------------ drawing
    def _shown_at(self, point: NDArray[np.float64]) -> NDArray[np.float64]:
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
        self.arrow_points = pv.PolyData(self.grid.copy())
        self.arrow_points.point_data.set_vectors(np.zeros_like(self.grid), VECTORS_ARRAY)
        glyphs = vtk.vtkGlyph3D()
        glyphs.SetInputData(self.arrow_points)
        glyphs.SetSourceData(pv.Arrow())
        glyphs.SetVectorModeToUseVector()
        glyphs.SetScaleModeToScaleByVector()  # arrows at true length: where each grid point goes
        glyphs.OrientOn()
        self._glyphs = glyphs
        self.arrow_actor = pl.add_mesh(glyphs, color="tomato", pickable=False)
        self._status = pl.add_text("", position="upper_left", font_size=9)

    def _add_widgets(self) -> None:
        pl = self.plotter
        self.slider = pl.add_slider_widget(
            lambda value: self._guarded(self.set_sigma, value),
            rng=(0.02 * self.size, self.size),
            value=self.sigma,
            title="kernel width sigma",
            pointa=(0.55, 0.12),
            pointb=(0.95, 0.12),
            style="modern",
            fmt="%.3g",
        )
        # a checkbox used as a push button: every click draws a new sample
        self.button = pl.add_checkbox_button_widget(lambda _: self._guarded(self.sample), position=(10, 10), size=30)
        pl.add_text("sample", position=(48, 14), font_size=10)
        pl.enable_point_picking(
            callback=lambda point, picker: self._guarded(self._on_pick, picker),
            use_picker=True,
            show_message=False,
            show_point=False,
        )
        self._widgets_on = True

    _widgets_on = False

    def _on_pick(self, picker: Any) -> None:
        vertex = int(picker.GetPointId())
        if picker.GetDataSet() is None or vertex < 0 or vertex >= self.mesh.n_points:
            return
        self.add_landmark(self.rest_points[vertex])

    def _add_landmark_widget(self, index: int) -> None:
        where, moved = self.landmarks[index]

        def dragged(center: Any) -> None:
            self._guarded(self.move_landmark, index, np.asarray(center) - where)

        self.plotter.add_sphere_widget(
            dragged,
            center=where + moved,
            radius=0.015 * self.size,
            color="orange",
            test_callback=False,
            interaction_event="always",
        )

    @staticmethod
    def _guarded(fn: Any, *args: Any) -> None:
        # PyVista turns exceptions in callbacks into warnings: log them where they can be read
        try:
            fn(*args)
        except Exception:
            log.exception("GPExplorer callback failed")
            raise

    def _refresh(self) -> None:
        process = self.process
        field = process.mean() if self._coefficients is None else process.instance(self._coefficients)
        n = len(self.rest_points)
        self.mesh.points[...] = self.rest_points + field[:n]
        self.arrow_points.point_data[VECTORS_ARRAY][...] = field[n:]
        self.arrow_points.Modified()
        if self._variance_stale:
            self.mesh.point_data[VARIANCE_ARRAY][...] = process.variance()[:n].sum(axis=1)
            self._variance_stale = False
        what = "sample" if self._coefficients is not None else "mean"
        shown = f"posterior {what}, {len(self.landmarks)} landmarks" if self.landmarks else f"prior {what}"
        status = f"{self.kernel_name} kernel, sigma = {self.sigma:.3g}, rank {process.rank}: {shown}"
        if self._widgets_on:
            status += "\nright-click or P over the mesh: add a landmark; drag its sphere to move it"
        self._status.SetText(2, status)
        self.plotter.render()
        push_to_browser(self.plotter)  # changes made from code reach an open notebook view
