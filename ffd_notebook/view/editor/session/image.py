"""The image shown with the mesh (``session.image``): three orthogonal slices warped through the session's FFD.

The slices follow every change of the session's deformation: :meth:`SessionImage.follow` runs
inside :meth:`~.session.EditingSession.notify`, before any view hears of the change, and notes the
control points that moved; the slices are brought up to date when they are next looked at (the
scene does it just before each render, so a drag's many mouse events cost one update per frame),
re-reading only the pixels whose ``T(x)`` the moved control points changed
(:class:`~ffd_notebook.images.WarpedSlices`). The scene copies only those pixels
(:meth:`SessionImage.take_unshown`). The convention is ITK's and :func:`~ffd_notebook.warp_image`'s: the pixel
at ``x`` shows the image at ``T(x)`` (a control point moved by ``+d`` pulls the content near it by
about ``-d``), which is what the saved lattice file does to the image in SimpleITK; saving writes
that warped image. The image follows the session's lattice with its options but not the mesh's
vertex weights (one per vertex: they say nothing of the image's voxels), so slices and saved image
show the lattice's whole deformation. No VTK here.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ....ffd.deform import FFD
from ....images import WarpedSlices, warp_image, write_image
from ....images.slices import intensity_window
from .changes import Change
from .lattices import copy_ffd

if TYPE_CHECKING:
    from .session import EditingSession

__all__ = ["SessionImage"]


class SessionImage:
    """The session's image, if any (``session.image``; see the module docstring).

    Attributes
    ----------
    window : tuple of float or None
        ``(level, width)`` of a grey image's display; None for a colour image.
    name : str
        What the panels call the image (its file name, or "image").
    box : mesh or None
        The image's box when it stands in for the mesh (a lattice over the image alone), else None.
    """

    def __init__(self, session: EditingSession) -> None:
        self.session = session
        self.window: tuple[float, float] | None = None
        self.name = ""
        self.box: Any = None
        self._slices: WarpedSlices | None = None
        self._pending: set[tuple[int, int, int]] | None = set()  # control points moved since the update; None: all
        self._last: dict[int, NDArray[np.bool_]] = {}  # pixels the last update re-read
        self._unshown: dict[int, NDArray[np.bool_]] = {}  # pixels re-read since the scene last copied them
        self._source: Any = None
        self._interpolation = "linear"

    @property
    def loaded(self) -> bool:
        """Whether an image is shown."""
        return self._slices is not None

    @property
    def slices(self) -> WarpedSlices | None:
        """The warped slices, up to date with the session's FFD (None until an image is loaded)."""
        self.update()
        return self._slices

    @property
    def regions(self) -> dict[int, NDArray[np.bool_]]:
        """Per slice axis, the pixels the last update re-read (all after a load, a new lattice, moved slices)."""
        self.update()
        return self._last

    def update(self) -> None:
        """Bring the slices up to date with the control points moved since the last update (cheap if none)."""
        if self._slices is None or self._pending == set():
            return
        changed = None if self._pending is None else sorted(self._pending)
        self._pending = set()
        regions = self._slices.update(changed)
        if any(region.any() for region in regions.values()):
            self._last = regions
            self._remember(regions)

    def take_unshown(self) -> dict[int, NDArray[np.bool_]]:
        """Bring the slices up to date; the pixels re-read since the last call (what a view must copy)."""
        self.update()
        unshown, self._unshown = self._unshown, {}
        return unshown

    def _remember(self, regions: dict[int, NDArray[np.bool_]]) -> None:
        for axis, region in regions.items():
            self._unshown[axis] = self._unshown[axis] | region if axis in self._unshown else region.copy()

    def _everything(self) -> None:
        """Every pixel was read again (a load, a new lattice, moved slices)."""
        assert self._slices is not None  # only called with an image loaded
        self._last = {axis: np.ones(v.shape[:2], dtype=bool) for axis, v in self._slices.values.items()}
        self._remember(self._last)

    def deformation(self, ffd: FFD | None = None) -> FFD:
        """``ffd`` (the session's by default) as the image follows it: its lattice (shared: drags move it), its
        options, no vertex weights.

        Examples
        --------
        >>> import numpy as np, pyvista as pv
        >>> from ffd_notebook.view.editor.session import EditingSession
        >>> from ffd_notebook.view.editor.editor import PYVISTA_MESH_IO
        >>> session = EditingSession(pv.Sphere(), mesh_io=PYVISTA_MESH_IO, shape=(4, 4, 4))
        >>> session.ffd.weights = np.ones(session.mesh.n_points)       # the mesh's vertex weights
        >>> ffd = session.image.deformation()
        >>> ffd.lattice is session.lattice, ffd.weights is None
        (True, True)
        """
        ffd = self.session.ffd if ffd is None else ffd
        return copy_ffd(ffd, ffd.lattice, weights=None)

    def _follows(self, ffd: FFD) -> bool:
        """Whether ``ffd`` is the session's FFD as the image follows it (see :meth:`deformation`)."""
        current = self.session.ffd
        options = ("basis", "border", "only_inside", "outside", "strength")
        return (
            ffd.lattice is current.lattice
            and ffd.weights is None
            and all(getattr(ffd, name) == getattr(current, name) for name in options)
            and np.array_equal(ffd.affine, current.affine)
        )

    def read(self, image: Any, *, interpolation: str = "linear") -> WarpedSlices:
        """Read and check ``image`` (a path, a SimpleITK image, an array with geometry) into slices; changes nothing.

        The slices are bound to the session's current FFD (worker-thread safe: the session is only read).
        """
        if isinstance(image, tuple):  # (array, {"spacing": ..., ...}) from code
            array, geometry = image
            return WarpedSlices(array, self.deformation(), interpolation=interpolation, **geometry)
        return WarpedSlices(image, self.deformation(), interpolation=interpolation)

    def use(self, slices: WarpedSlices, source: Any, name: str = "image", interpolation: str = "linear") -> None:
        """Show ``slices`` (from :meth:`read`): one ``"image"`` change labelled ``"load image"``."""
        grey = slices.values[slices.axes[0]].ndim == 2
        self._slices, self._source, self.name, self._interpolation = slices, source, name, interpolation
        self.window = intensity_window(slices.pixels) if grey else None
        if not self._follows(slices.ffd):  # another lattice (or options) since it was read: bound again
            slices.set_ffd(self.deformation())
            self._pending = set()
        else:  # read (in a worker thread, say) while control points moved: those catch up at the next look
            self._pending = {(int(i), int(j), int(k)) for i, j, k in np.ndindex(*self.session.lattice.shape)}
        self._unshown = {}
        self._everything()
        self.session.notify("image", None, "load image")

    def load(self, image: Any, *, interpolation: str = "linear") -> None:
        """Read and show an image; a bad file leaves the session as it was (a message says why, and it raises).

        A path is read by :func:`~ffd_notebook.images.read_image`: whole or refused, and a MetaImage or NRRD
        header reads the data files it names wherever they are, as ITK does (the standalone app reads only
        those inside its folder).
        """
        slices = self.read(image, interpolation=interpolation)
        name = os.path.basename(os.fspath(image)) if isinstance(image, str | os.PathLike) else "image"
        self.use(slices, image, name, interpolation)
        self.session.info(f"Loaded image {name}: {' x '.join(map(str, slices.grid.size))} voxels")

    def follow(self, change: Change) -> None:
        """Note what one session change does to the slices (called by ``session.notify`` first)."""
        if self._slices is None:
            return
        if change.kind in ("drag", "offsets"):
            if change.points is None or self._pending is None:
                self._pending = None
            else:
                ijk = np.column_stack(np.unravel_index(change.points, self.session.lattice.shape))
                self._pending.update((int(i), int(j), int(k)) for i, j, k in ijk)
        elif change.kind == "lattice":
            self._slices.set_ffd(self.deformation())
            self._pending = set()
            self._everything()

    def require(self) -> WarpedSlices:
        """The slices, up to date; a ValueError if no image is loaded."""
        slices = self.slices
        if slices is None:
            raise ValueError("no image is loaded")
        return slices

    def set_window(self, window: Any) -> None:
        """Show grey values ``level - width/2 .. level + width/2`` from black to white; ``window = (level, width)``."""
        self.require()
        level, width = (float(v) for v in window)
        if self.window is None:
            raise ValueError("a colour image has no window/level")
        if not (np.isfinite(level) and np.isfinite(width) and width > 0):
            raise ValueError(f"the window needs a finite level and a positive width, got {level!r}, {width!r}")
        self.window = (float(level), float(width))
        self.session.notify("image", None, "window")

    def set_positions(self, positions: Any) -> None:
        """Move the slices to voxel indices ``(i, j, k)`` (clipped into the image)."""
        slices = self.require()
        wanted = [int(p) for p in np.asarray(positions).reshape(-1)]
        if len(wanted) != slices.grid.dim:
            raise ValueError(f"slice positions need {slices.grid.dim} indices, got {positions!r}")
        for axis in slices.axes:
            if wanted[axis] != slices.positions[axis]:
                slices.set_position(axis, wanted[axis])
        self._everything()
        self.session.notify("image", None, "slices")

    def beside(self, lattice_path: str | os.PathLike[str]) -> Path:
        """Where saving the lattice ``lattice.ffd`` puts the warped image: ``lattice.warped.nii.gz`` (the
        image's format; NRRD for an image given as an array)."""
        from ....images import image_suffix

        source = self._source
        suffix = image_suffix(source) if isinstance(source, str | os.PathLike) else ".nrrd"
        target = Path(lattice_path)
        return target.with_name(f"{target.stem}.warped{suffix}")

    def _loaded_slices(self) -> WarpedSlices:
        """The slices as they are, not brought up to date (a worker thread may ask); a ValueError if none."""
        if self._slices is None:
            raise ValueError("no image is loaded")
        return self._slices

    def warped(self, ffd: FFD | None = None) -> Any:
        """The whole image warped through ``ffd`` (the session's by default), as the image follows it
        (:meth:`deformation`: no vertex weights): what :meth:`save` writes."""
        self._loaded_slices()
        return warp_image(self._source, self.deformation(ffd), interpolation=self._interpolation)

    def save(self, path: str | os.PathLike[str], *, announce: bool = True, ffd: FFD | None = None) -> None:
        """Write the image warped through ``ffd`` (the session's by default; SimpleITK's formats, by extension),
        atomically. A worker thread may call it with ``announce=False`` (then it only writes) and a copy of the
        session's FFD taken when saving was asked for (then edits made meanwhile are not half in the file)."""
        grid = self._loaded_slices().grid
        warped = self.warped(ffd)
        if not hasattr(warped, "GetSize"):  # an array image: give it its geometry
            import SimpleITK as sitk

            warped = grid.to_sitk(sitk.GetImageFromArray(warped, isVector=warped.ndim > grid.dim))
        write_image(path, warped)
        if announce:
            self.session.info(f"Saved the warped image to {os.path.basename(os.fspath(path))}")
