"""Dense displacement fields (NIfTI, NRRD, MetaImage), in ITK's convention, read and written with SimpleITK.

A field is a 3D image of 3-vectors: the voxel ``(i, j, k)`` sits at ``origin + direction @
(spacing * (i, j, k))`` and holds the displacement of that point in physical (LPS) coordinates,
what ``sitk.DisplacementFieldTransform``, ANTs and nitransforms read. Between voxel centres
:class:`DisplacementField` interpolates linearly as ITK's ``VectorLinearInterpolateImageFunction``
does (the neighbours clamped to the grid), inside the buffer's half-voxel margin
(``-0.5 <= index < n - 0.5`` on every axis, ``ImageFunction::IsInsideBuffer``); a point outside it
does not move (``DisplacementFieldTransform::TransformPoint``). That is the images' interpolator,
:class:`~ffd_notebook.images.pixels.Interpolator` (linear, default value zero), reading the vectors.
NiftyReg's own fields follow another rule beyond their grid (``outside="nearest"``): the displacement of
the nearest border voxel goes on (``get_SlidedValues`` in NiftyReg's ``_reg_splineBasis.cpp``), the same
interpolator reading at the index clamped onto the grid.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._util.points import as_points
from ..errors import FileFormatError
from ..ffd.grid import GridEvaluator
from ..images.files import open_image
from ..images.geometry import ImageGrid
from ..images.pixels import Interpolator
from ..images.reference import reference_grid
from ._atomic import atomic_path

__all__ = [
    "FIELD_SUFFIXES",
    "DisplacementField",
    "field_suffix",
    "load_displacement_field",
    "sample_displacement_field",
    "save_displacement_field",
]

#: What moves a point beyond a field's grid (:class:`DisplacementField`'s ``outside``).
FIELD_OUTSIDE_RULES = ("zero", "nearest")
#: Displacement-field file names, and the ITK image IO that reads and writes each.
FIELD_SUFFIXES = {".nii": "NiftiImageIO", ".nii.gz": "NiftiImageIO", ".nrrd": "NrrdImageIO", ".mha": "MetaImageIO"}
_MAX_VOXELS = 2**28  # 268M voxels: 6.4 GB of float64 vectors, far above any registration field
_SLAB_POINTS = 1 << 20  # points deformed at a time when sampling a field


def field_suffix(path: str | os.PathLike[str]) -> str | None:
    """The displacement-field suffix of a file name (``".nii.gz"`` counts as one), or ``None``.

    Examples
    --------
    >>> field_suffix("warp.NII.GZ"), field_suffix("a.nrrd"), field_suffix("a.txt")
    ('.nii.gz', '.nrrd', None)
    """
    name = Path(path).name.lower()
    return next((s for s in sorted(FIELD_SUFFIXES, key=len, reverse=True) if name.endswith(s)), None)


class DisplacementField:
    """A displacement field on a regular grid, moving points as ``sitk.DisplacementFieldTransform`` does.

    The vectors are in SimpleITK's (and scikit-image's) array order, as every 3D grid of the package:
    ``vectors[k, j, i]`` is the displacement of voxel ``(i, j, k)``, what ``sitk.GetArrayFromImage``
    gives for a vector image (:meth:`from_sitk`, :meth:`to_sitk`). The grid's ``size``, ``spacing``
    and ``origin`` are listed x first (ITK's order), ``shape`` is the array's.

    Parameters
    ----------
    vectors : array_like
        ``(nz, ny, nx, 3)`` displacements in physical units, ``vectors[k, j, i]`` the voxel ``(i, j, k)``'s.
    spacing, origin : array_like, optional
        Voxel spacing and the position of voxel ``(0, 0, 0)`` (x first); 1 and 0 by default.
    direction : array_like, optional
        3x3 matrix whose columns are the grid axes (identity by default).
    outside : {"zero", "nearest"}
        What moves a point outside the buffer: nothing (``"zero"``, ITK's ``DisplacementFieldTransform``, ANTs)
        or the displacement of the nearest border voxel (``"nearest"``, NiftyReg's fields, which interpolate with
        their border voxels repeated beyond the grid).

    Examples
    --------
    >>> import numpy as np
    >>> vectors = np.zeros((3, 3, 3, 3)); vectors[:, :, 2, 0] = 1.0     # the voxels at i = 2 move by 1 in x
    >>> field = DisplacementField(vectors, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0))
    >>> field.deform([[1.5, 1.0, 1.0], [2.4, 1.0, 1.0], [2.6, 1.0, 1.0]]).tolist()
    [[2.0, 1.0, 1.0], [3.4, 1.0, 1.0], [2.6, 1.0, 1.0]]
    """

    def __init__(
        self,
        vectors: ArrayLike,
        spacing: ArrayLike | None = None,
        origin: ArrayLike | None = None,
        direction: ArrayLike | None = None,
        *,
        outside: str = "zero",
    ) -> None:
        if outside not in FIELD_OUTSIDE_RULES:
            raise ValueError(f"outside must be one of {', '.join(FIELD_OUTSIDE_RULES)}, got {outside!r}")
        self.outside = outside
        v = np.asarray(vectors, dtype=np.float64)
        if v.ndim != 4 or v.shape[3] != 3 or min(v.shape[:3]) < 1:
            raise ValueError(f"vectors must be an (nz, ny, nx, 3) array (array order, as images), got shape {v.shape}")
        if not np.all(np.isfinite(v)):
            raise ValueError("the displacement vectors contain NaN or infinite values")
        try:
            grid = ImageGrid(v.shape[2::-1], spacing, origin, direction)
        except ValueError as exc:
            raise ValueError(f"the field's grid: {exc}") from None
        if np.linalg.cond(grid.direction * grid.spacing) > 1e12:
            raise ValueError("the grid needs a positive spacing, a finite origin and an invertible direction")
        self.vectors: NDArray[np.float64] = v
        self.grid: ImageGrid = grid
        self._to_index = grid.physical_to_index()[:3]
        self._interpolator: Interpolator | None = None
        self._interpolator_of: NDArray[np.float64] | None = None

    @classmethod
    def from_sitk(cls, image: Any) -> DisplacementField:
        """The field a SimpleITK vector image holds (3D, three components), in ITK's convention.

        Parameters
        ----------
        image : SimpleITK.Image
            A 3D image of 3-vectors (``sitk.sitkVectorFloat64`` or any vector pixel type).

        Returns
        -------
        DisplacementField
            Its vectors (``sitk.GetArrayFromImage(image)``) on its grid.

        Raises
        ------
        ValueError
            Not a 3D image of 3-vectors.

        Examples
        --------
        >>> import numpy as np, SimpleITK as sitk
        >>> image = sitk.GetImageFromArray(np.ones((2, 3, 4, 3)), isVector=True)
        >>> DisplacementField.from_sitk(image).size
        (4, 3, 2)
        """
        import SimpleITK as sitk

        if image.GetDimension() != 3 or image.GetNumberOfComponentsPerPixel() != 3:
            raise ValueError(
                f"a displacement field is a 3D image of 3-vectors, got {image.GetDimension()}D with "
                f"{image.GetNumberOfComponentsPerPixel()} component(s) per voxel"
            )
        grid = ImageGrid.of(image)
        return cls(sitk.GetArrayFromImage(image), grid.spacing, grid.origin, grid.direction)

    def to_sitk(self) -> Any:
        """The field as a SimpleITK vector image (``sitkVectorFloat64``) on its grid.

        Returns
        -------
        SimpleITK.Image
            What ``sitk.DisplacementFieldTransform`` takes.

        Examples
        --------
        >>> import numpy as np
        >>> field = DisplacementField(np.ones((2, 3, 4, 3)), spacing=0.5)
        >>> image = field.to_sitk()
        >>> image.GetSize(), image.GetSpacing()
        ((4, 3, 2), (0.5, 0.5, 0.5))
        """
        import SimpleITK as sitk

        return self.grid.to_sitk(sitk.GetImageFromArray(self.vectors, isVector=True))

    @property
    def shape(self) -> tuple[int, int, int]:
        """The array's shape without the components, ``(nz, ny, nx)`` (``size`` reversed)."""
        return cast("tuple[int, int, int]", tuple(int(n) for n in self.vectors.shape[:3]))

    @property
    def size(self) -> tuple[int, int, int]:
        """Voxels per axis, x first: ``(nx, ny, nz)`` (ITK's ``GetSize()``)."""
        return cast("tuple[int, int, int]", self.grid.size)

    @property
    def spacing(self) -> NDArray[np.float64]:
        """Voxel spacing, x first."""
        return self.grid.spacing

    @property
    def origin(self) -> NDArray[np.float64]:
        """Physical position of voxel ``(0, 0, 0)``."""
        return self.grid.origin

    @property
    def direction(self) -> NDArray[np.float64]:
        """3x3 matrix whose columns are the grid's axes."""
        return self.grid.direction

    def grid_points(self) -> NDArray[np.float64]:
        """Every voxel centre, ``(nx * ny * nz, 3)``, in the order of ``vectors.reshape(-1, 3)`` (i fastest).

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` physical positions of the voxel centres (``self.grid.physical_points()``).

        Examples
        --------
        >>> import numpy as np
        >>> field = DisplacementField(np.zeros((3, 3, 3, 3)), spacing=2.0)
        >>> field.grid_points()[[0, 1, -1]].tolist()
        [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [4.0, 4.0, 4.0]]
        """
        return self.grid.physical_points()

    def to_index(self, points: ArrayLike) -> NDArray[np.float64]:
        """Continuous voxel indices ``(i, j, k)`` of world points, ``(N, 3)``.

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points in physical coordinates.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` continuous voxel indices ``(i, j, k)`` (x first).

        Examples
        --------
        >>> import numpy as np
        >>> field = DisplacementField(np.zeros((3, 3, 3, 3)), spacing=2.0)
        >>> field.to_index([[2.0, 3.0, 0.0]]).tolist()
        [[1.0, 1.5, 0.0]]
        """
        pts = as_points(points)
        return pts @ self._to_index[:, :3].T + self._to_index[:, 3]

    def displacement(self, points: ArrayLike) -> NDArray[np.float64]:
        """The interpolated displacement at each point (zero outside the buffer), ``(N, 3)``.

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points in physical coordinates.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` interpolated displacements (zero outside the buffer).

        Examples
        --------
        >>> import numpy as np
        >>> vectors = np.zeros((3, 3, 3, 3)); vectors[..., 0] = 1.0     # every voxel moves +1 in x
        >>> field = DisplacementField(vectors, spacing=2.0)
        >>> field.displacement([[1.0, 1.0, 1.0]]).tolist()
        [[1.0, 0.0, 0.0]]
        """
        index = self.to_index(points)
        if self.outside == "nearest":  # NiftyReg: beyond the grid, the border voxels' displacement goes on
            index = np.clip(index, 0.0, np.array(self.size, dtype=np.float64) - 1.0)  # NaN stays NaN: zero
        out = np.empty_like(index)
        self._reader().read(np.ascontiguousarray(index.T[::-1]), out=out)  # array order (k, j, i)
        return out

    def _reader(self) -> Interpolator:
        """The images' linear interpolator on the vectors (made again if ``vectors`` was replaced)."""
        if self._interpolator is None or self._interpolator_of is not self.vectors:
            self._interpolator = Interpolator(self.vectors, self.grid, "linear", 0.0)
            self._interpolator_of = self.vectors
        return self._interpolator

    def deform(self, points: ArrayLike) -> NDArray[np.float64]:
        """Where the field takes ``(N, 3)`` points: ``x + displacement(x)``.

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points in physical coordinates.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` moved points (points outside the buffer stay).

        Examples
        --------
        >>> import numpy as np
        >>> vectors = np.zeros((3, 3, 3, 3)); vectors[..., 0] = 1.0     # every voxel moves +1 in x
        >>> field = DisplacementField(vectors, spacing=2.0)
        >>> field.deform([[1.0, 1.0, 1.0], [50.0, 0.0, 0.0]]).tolist()
        [[2.0, 1.0, 1.0], [50.0, 0.0, 0.0]]
        """
        pts = as_points(points)
        return pts + self.displacement(pts)

    __call__ = deform

    def __repr__(self) -> str:
        rule = "" if self.outside == "zero" else f", outside={self.outside!r}"
        return (f"DisplacementField(size={self.size}, spacing={self.spacing.tolist()}, "
                f"origin={self.origin.tolist()}{rule})")  # fmt: skip


def _first_line(exc: BaseException) -> str:
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    return lines[-1][:200] if lines else type(exc).__name__


class _Callable:
    """A callable on ``(N, 3)`` points as a deformation (``deform``)."""

    def __init__(self, function: Callable[[NDArray[np.float64]], Any]) -> None:
        self.function = function

    def deform(self, points: NDArray[np.float64]) -> Any:
        return self.function(points)


def _as_deformation(deformation: Any) -> Any:
    if callable(getattr(deformation, "deform", None)):
        return deformation
    if callable(deformation):
        return _Callable(deformation)
    raise TypeError(f"expected a deformation (an object with deform(points), or a callable), got "
                    f"{type(deformation).__name__}")  # fmt: skip


def sample_displacement_field(deformation: Any, reference: Any) -> DisplacementField:
    """A deformation sampled at the voxel centres of a reference grid: ``T(x) - x``.

    ``deformation`` is anything with ``deform(points)`` (an :class:`~ffd_notebook.FFD`, an
    :class:`~ffd_notebook.io.ElastixTransform`, a field) or a callable on ``(N, 3)`` points;
    ``reference`` anything :func:`~ffd_notebook.images.reference_grid` reads. It is evaluated by the
    engine's one evaluator on a grid (:class:`~ffd_notebook.ffd.grid.GridEvaluator`): separably for an
    FFD whose lattice runs along the grid, with every option of the FFD (an FFD's per-point weights
    are then one per voxel, in array order), point by point otherwise.

    Parameters
    ----------
    deformation : FFD, ElastixTransform, DisplacementField or callable
        What moves points (a callable maps ``(N, 3)`` points to moved points).
    reference : ImageGrid, image, image file, DisplacementField or mapping
        The grid: anything :func:`~ffd_notebook.images.reference_grid` reads (a mapping with ``size`` and
        optionally ``spacing``, ``origin``, ``direction``).

    Returns
    -------
    DisplacementField
        The deformation's displacements at the grid's voxel centres.

    Examples
    --------
    >>> from ffd_notebook import FFD, Lattice
    >>> lat = Lattice((4, 4, 4), 1.0, origin=(-1.0, -1.0, -1.0)); lat.offsets[...] = (0.5, 0.0, 0.0)
    >>> field = sample_displacement_field(FFD(lat), {"size": (2, 2, 2)})
    >>> field.vectors[1, 1, 1].round(12).tolist()
    [0.5, 0.0, 0.0]
    >>> sample_displacement_field(FFD(lat, strength=0.5), {"size": (2, 2, 2)}).vectors[1, 1, 1].round(12).tolist()
    [0.25, 0.0, 0.0]
    """
    grid = reference_grid(reference)
    if grid.dim != 3:
        raise ValueError(f"a displacement field needs a 3D reference grid, got a {grid.dim}D one")
    if int(np.prod(grid.size)) > _MAX_VOXELS:
        raise ValueError(f"a reference grid of {grid.size} voxels: expected at most {_MAX_VOXELS} voxels")
    evaluator = GridEvaluator(_as_deformation(deformation), grid.index_to_physical(), grid.shape)
    nz, ny, nx = grid.shape
    vectors = np.empty((nz, ny, nx, 3))
    per_slab = max(1, _SLAB_POINTS // (ny * nx))
    for start in range(0, nz, per_slab):
        stop = min(nz, start + per_slab)
        vectors[start:stop] = np.moveaxis(evaluator.displacements(start, stop), 0, -1)
    return DisplacementField(vectors, grid.spacing, grid.origin, grid.direction)


# ---------------------------------------------------------------------------------------- files
def _check_suffix(path: str | os.PathLike[str]) -> str:
    suffix = field_suffix(path)
    if suffix is None:
        raise ValueError(f"{os.fspath(path)}: a displacement field file must end in one of "
                         f"{', '.join(FIELD_SUFFIXES)}")  # fmt: skip
    return suffix


def save_displacement_field(path: str | os.PathLike[str], deformation: Any, reference: Any = None) -> None:
    """Sample a deformation on a reference grid and write it as a displacement field, atomically.

    The file (``.nii``, ``.nii.gz``, ``.nrrd`` or ``.mha``, by extension) holds float64
    vectors in physical coordinates, ITK's convention: ``sitk.DisplacementFieldTransform`` of it
    moves each voxel centre where ``deformation`` does. ``deformation`` may be a
    :class:`DisplacementField` already (``reference`` then defaults to its own grid).

    Parameters
    ----------
    path : path-like
        The file to write.
    deformation : FFD, ElastixTransform, DisplacementField or callable
        What moves points (see :func:`sample_displacement_field`).
    reference : image file, SimpleITK image, DisplacementField or mapping
        The voxel grid: size, spacing, origin, direction.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from ffd_notebook import FFD, Lattice
    >>> lat = Lattice((4, 4, 4), 2.0, origin=(-2.0, -2.0, -2.0)); lat.offsets[1, 1, 1] = (0.0, 1.0, 0.0)
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "warp.nii.gz"
    >>> save_displacement_field(path, FFD(lat), {"size": (3, 3, 3), "spacing": 1.0})
    >>> load_displacement_field(path).shape
    (3, 3, 3)
    """
    import SimpleITK as sitk

    suffix = _check_suffix(path)
    if reference is None:
        if not isinstance(deformation, DisplacementField):
            raise ValueError("a reference grid is needed to sample this deformation (an image, a field or a mapping)")
        field = deformation
    elif isinstance(deformation, DisplacementField) and deformation.grid == reference_grid(reference):
        field = deformation
    else:
        field = sample_displacement_field(deformation, reference)
    image = field.to_sitk()
    writer = sitk.ImageFileWriter()
    writer.SetImageIO(FIELD_SUFFIXES[suffix])
    writer.SetUseCompression(suffix == ".nii.gz")
    with atomic_path(path) as tmp:
        # ITK's IO needs the real extension and no other (NIfTI drops a doubled one); renamed onto tmp at once
        staging = tmp.with_name("." + tmp.name.replace(".", "_") + suffix)
        try:
            writer.SetFileName(os.fspath(staging))
            writer.Execute(image)
            os.replace(staging, tmp)
        finally:
            staging.unlink(missing_ok=True)


def load_displacement_field(path: str | os.PathLike[str], *, within: str | os.PathLike[str] | None = None
                            ) -> DisplacementField:  # fmt: skip
    """Read a displacement field file (``.nii``, ``.nii.gz``, ``.nrrd``, ``.mha``), whole or not at all.

    The file goes through the package's one image reader (:func:`~ffd_notebook.images.open_image`):
    its header is checked before ITK reads it (a MetaImage or NRRD header that names data files
    reads them only inside ``within``), and its vectors are read whole or refused (a file cut
    short says how many bytes of how many it holds). A field with a NaN or infinite component
    anywhere is refused, naming how many vectors have one: SimpleITK's NIfTI reader turns them
    into 0 (no displacement) without a word, so they are counted in the file's own data.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.nii``, ``.nii.gz``, ``.nrrd`` or ``.mha`` file of 3-vectors.
    within : str or os.PathLike, optional
        The folder the files its header names must be in (the app passes its folder); ``None``:
        anywhere, as ITK reads it.

    Returns
    -------
    DisplacementField
        The field, in ITK's convention.

    Raises
    ------
    FileFormatError
        Not an image the package reads, not 3D, not 3 components per voxel, too large, data that
        ends early, a data file refused, or non-finite vectors; names the file.

    Examples
    --------
    >>> import numpy as np
    >>> from ffd_notebook.io import DisplacementField
    >>> vectors = np.zeros((3, 3, 3, 3)); vectors[..., 0] = 1.0     # every voxel moves +1 in x
    >>> field = DisplacementField(vectors, spacing=2.0, origin=(0.0, 0.0, 0.0))
    >>> import pathlib, tempfile
    >>> from ffd_notebook.io import save_displacement_field
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "warp.nii.gz"
    >>> save_displacement_field(path, field)
    >>> load_displacement_field(path).deform([[1.0, 1.0, 1.0]]).tolist()
    [[2.0, 1.0, 1.0]]
    >>> vectors[1, 1, 1] = np.nan
    >>> import SimpleITK as sitk
    >>> sitk.WriteImage(sitk.GetImageFromArray(vectors, isVector=True), str(path))
    >>> load_displacement_field(path)
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.FileFormatError: ...warp.nii.gz: 1 of its 27 vectors hold NaN or infinite values: refused
    """
    import SimpleITK as sitk

    _check_suffix(path)
    image_file = open_image(path, within=within)
    dims, components = image_file.dimension, image_file.components
    if dims != 3 or components != 3:
        raise FileFormatError(path, None, f"expected a 3D image of 3-vectors (a displacement field), got "
                              f"{dims}D with {components} component(s) per voxel")  # fmt: skip
    size = image_file.grid.size
    if int(np.prod(size)) > _MAX_VOXELS:
        raise FileFormatError(path, None, f"a field of {size} voxels is larger than the limit ({_MAX_VOXELS})")
    image = image_file.read(pixel_type=sitk.sitkVectorFloat64, finite=True)
    try:
        return DisplacementField.from_sitk(image)
    except ValueError as exc:
        raise FileFormatError(path, None, str(exc)) from None
