"""Dense displacement fields (NIfTI, NRRD, MetaImage), in ITK's convention, read and written with SimpleITK.

A field is a 3D image of 3-vectors: the voxel ``(i, j, k)`` sits at ``origin + direction @
(spacing * (i, j, k))`` and holds the displacement of that point in physical (LPS) coordinates,
what ``sitk.DisplacementFieldTransform``, ANTs and nitransforms read. Between voxel centres
:class:`DisplacementField` interpolates linearly as ITK's ``VectorLinearInterpolateImageFunction``
does (the neighbours clamped to the grid), inside the buffer's half-voxel margin
(``-0.5 <= index < n - 0.5`` on every axis, ``ImageFunction::IsInsideBuffer``); a point outside it
does not move (``DisplacementFieldTransform::TransformPoint``). NiftyReg's own fields follow another
rule beyond their grid (``outside="nearest"``): the displacement of the nearest border voxel goes on
(``get_SlidedValues`` in NiftyReg's ``_reg_splineBasis.cpp``).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._util.points import as_points
from ..errors import FileFormatError
from ..ffd.deform import FFD
from ._atomic import atomic_path
from ._safety import check_regular_file
from .tensor_grid import apply_along, axis_weights

__all__ = [
    "FIELD_SUFFIXES",
    "DisplacementField",
    "field_suffix",
    "load_displacement_field",
    "reference_grid",
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

    Parameters
    ----------
    vectors : array_like
        ``(nx, ny, nz, 3)`` displacements (physical units), index ``(i, j, k)`` as the voxel's.
    spacing, origin : array_like
        Voxel spacing and the position of voxel ``(0, 0, 0)``.
    direction : array_like, optional
        3x3 matrix whose columns are the grid axes (identity by default).
    outside : {"zero", "nearest"}
        What moves a point outside the buffer: nothing (``"zero"``, ITK's ``DisplacementFieldTransform``, ANTs)
        or the displacement of the nearest border voxel (``"nearest"``, NiftyReg's fields, which interpolate with
        their border voxels repeated beyond the grid).

    Examples
    --------
    >>> import numpy as np
    >>> vectors = np.zeros((3, 3, 3, 3)); vectors[2, :, :, 0] = 1.0     # the x = 2 layer moves by 1 in x
    >>> field = DisplacementField(vectors, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0))
    >>> field.deform([[1.5, 1.0, 1.0], [2.4, 1.0, 1.0], [2.6, 1.0, 1.0]]).tolist()
    [[2.0, 1.0, 1.0], [3.4, 1.0, 1.0], [2.6, 1.0, 1.0]]
    """

    def __init__(
        self,
        vectors: ArrayLike,
        spacing: ArrayLike,
        origin: ArrayLike,
        direction: ArrayLike | None = None,
        *,
        outside: str = "zero",
    ):
        if outside not in FIELD_OUTSIDE_RULES:
            raise ValueError(f"outside must be one of {', '.join(FIELD_OUTSIDE_RULES)}, got {outside!r}")
        self.outside = outside
        v = np.asarray(vectors, dtype=np.float64)
        if v.ndim != 4 or v.shape[3] != 3 or min(v.shape[:3]) < 1:
            raise ValueError(f"vectors must be an (nx, ny, nz, 3) array, got shape {v.shape}")
        if not np.all(np.isfinite(v)):
            raise ValueError("the displacement vectors contain NaN or infinite values")
        self.vectors: NDArray[np.float64] = v
        self.spacing = np.broadcast_to(np.asarray(spacing, dtype=np.float64), (3,)).copy()
        self.origin = np.asarray(origin, dtype=np.float64).reshape(3).copy()
        self.direction = np.eye(3) if direction is None else np.asarray(direction, dtype=np.float64).reshape(3, 3)
        placement = self.direction * self.spacing
        if (not np.all(np.isfinite(placement)) or not np.all(np.isfinite(self.origin)) or np.any(self.spacing <= 0)
                or np.linalg.cond(placement) > 1e12):  # fmt: skip
            raise ValueError("the grid needs a positive spacing, a finite origin and an invertible direction")
        self._to_index = np.linalg.inv(placement)

    @property
    def shape(self) -> tuple[int, int, int]:
        """Voxels per axis ``(nx, ny, nz)``."""
        return tuple(int(n) for n in self.vectors.shape[:3])  # type: ignore[return-value]

    def grid_points(self) -> NDArray[np.float64]:
        """Every voxel centre, ``(nx * ny * nz, 3)``, in the order of ``vectors.reshape(-1, 3)``.

        Returns
        -------
        numpy.ndarray
            ``(nx * ny * nz, 3)`` physical positions of the voxel centres, x index slowest.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.io import DisplacementField
        >>> vectors = np.zeros((3, 3, 3, 3)); vectors[..., 0] = 1.0     # every voxel moves +1 in x
        >>> field = DisplacementField(vectors, spacing=2.0, origin=(0.0, 0.0, 0.0))
        >>> field.grid_points()[[0, -1]].tolist()
        [[0.0, 0.0, 0.0], [4.0, 4.0, 4.0]]
        """
        index = np.stack(np.meshgrid(*[np.arange(n, dtype=np.float64) for n in self.shape], indexing="ij"), -1)
        return index.reshape(-1, 3) @ (self.direction * self.spacing).T + self.origin

    def to_index(self, points: ArrayLike) -> NDArray[np.float64]:
        """Continuous voxel indices of world points, ``(N, 3)``.

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points in physical coordinates.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` continuous voxel indices ``(i, j, k)``.

        Examples
        --------
        >>> import numpy as np
        >>> from ffd_notebook.io import DisplacementField
        >>> vectors = np.zeros((3, 3, 3, 3)); vectors[..., 0] = 1.0     # every voxel moves +1 in x
        >>> field = DisplacementField(vectors, spacing=2.0, origin=(0.0, 0.0, 0.0))
        >>> field.to_index([[2.0, 3.0, 0.0]]).tolist()
        [[1.0, 1.5, 0.0]]
        """
        return (as_points(points) - self.origin) @ self._to_index.T

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
        >>> from ffd_notebook.io import DisplacementField
        >>> vectors = np.zeros((3, 3, 3, 3)); vectors[..., 0] = 1.0     # every voxel moves +1 in x
        >>> field = DisplacementField(vectors, spacing=2.0, origin=(0.0, 0.0, 0.0))
        >>> field.displacement([[1.0, 1.0, 1.0]]).tolist()
        [[1.0, 0.0, 0.0]]
        """
        index = self.to_index(points)
        dims = np.array(self.shape, dtype=np.float64)
        if self.outside == "nearest":
            inside = np.all(np.isfinite(index), axis=1)
        else:
            inside = np.all((index >= -0.5) & (index < dims - 0.5), axis=1)
        out = np.zeros_like(index)
        if not inside.any():
            return out
        c = np.clip(index[inside], 0.0, dims - 1.0)
        base = np.minimum(np.floor(c), np.maximum(dims - 2.0, 0.0)).astype(np.int64)
        t = c - base
        upper = np.minimum(base + 1, np.array(self.shape) - 1)
        acc = np.zeros((len(c), 3))
        for corner in range(8):
            bits = [(corner >> a) & 1 for a in range(3)]
            weight = np.ones(len(c))
            ijk = []
            for a, bit in enumerate(bits):
                weight *= t[:, a] if bit else 1.0 - t[:, a]
                ijk.append(upper[:, a] if bit else base[:, a])
            acc += weight[:, None] * self.vectors[ijk[0], ijk[1], ijk[2]]
        out[inside] = acc
        return out

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
        >>> from ffd_notebook.io import DisplacementField
        >>> vectors = np.zeros((3, 3, 3, 3)); vectors[..., 0] = 1.0     # every voxel moves +1 in x
        >>> field = DisplacementField(vectors, spacing=2.0, origin=(0.0, 0.0, 0.0))
        >>> field.deform([[1.0, 1.0, 1.0], [50.0, 0.0, 0.0]]).tolist()
        [[2.0, 1.0, 1.0], [50.0, 0.0, 0.0]]
        """
        pts = as_points(points)
        return pts + self.displacement(pts)

    __call__ = deform

    def __repr__(self) -> str:
        rule = "" if self.outside == "zero" else f", outside={self.outside!r}"
        return (f"DisplacementField(shape={self.shape}, spacing={self.spacing.tolist()}, "
                f"origin={self.origin.tolist()}{rule})")  # fmt: skip


# ---------------------------------------------------------------------------------------- reference grids
def _grid_of(reference: Any) -> tuple[tuple[int, int, int], NDArray, NDArray, NDArray]:
    """``(size, spacing, origin, direction)`` of a reference: an image file, a SimpleITK image, a field or a mapping."""
    import SimpleITK as sitk

    if isinstance(reference, DisplacementField):
        return reference.shape, reference.spacing, reference.origin, reference.direction
    if isinstance(reference, (str, os.PathLike)):
        check_regular_file(reference)
        reader = sitk.ImageFileReader()
        reader.SetFileName(os.fspath(reference))
        try:
            reader.ReadImageInformation()
        except RuntimeError as exc:
            raise FileFormatError(reference, None, f"not an image SimpleITK can read: {_first_line(exc)}") from None
        if reader.GetDimension() != 3:
            raise FileFormatError(reference, None, f"expected a 3D image, got {reader.GetDimension()}D")
        return (tuple(reader.GetSize()), np.array(reader.GetSpacing()), np.array(reader.GetOrigin()),
                np.array(reader.GetDirection()).reshape(3, 3))  # fmt: skip
    if isinstance(reference, sitk.Image):
        if reference.GetDimension() != 3:
            raise ValueError(f"expected a 3D reference image, got {reference.GetDimension()}D")
        return (tuple(reference.GetSize()), np.array(reference.GetSpacing()), np.array(reference.GetOrigin()),
                np.array(reference.GetDirection()).reshape(3, 3))  # fmt: skip
    if isinstance(reference, Mapping):
        unknown = set(reference) - {"size", "spacing", "origin", "direction"}
        if "size" not in reference or unknown:
            raise ValueError("a reference grid given as a mapping needs 'size' and may have 'spacing', 'origin', "
                             f"'direction' (got {sorted(reference)})")  # fmt: skip
        size = tuple(int(n) for n in np.asarray(reference["size"]).reshape(3))
        spacing = np.broadcast_to(np.asarray(reference.get("spacing", 1.0), dtype=np.float64), (3,)).copy()
        origin = np.asarray(reference.get("origin", (0.0, 0.0, 0.0)), dtype=np.float64).reshape(3)
        direction = np.asarray(reference.get("direction", np.eye(3)), dtype=np.float64).reshape(3, 3)
        return size, spacing, origin, direction  # type: ignore[return-value]
    raise TypeError("reference must be an image file, a SimpleITK image, a DisplacementField or a mapping with "
                    f"size/spacing/origin/direction, got {type(reference).__name__}")  # fmt: skip


def reference_grid(reference: Any) -> dict[str, Any]:
    """A reference's voxel grid as ``{"size", "spacing", "origin", "direction"}`` .

    ``reference``: an image file, a SimpleITK image, a :class:`DisplacementField` or such a mapping
    (``size`` required; spacing 1, origin 0 and identity direction by default).

    Examples
    --------
    >>> reference_grid({"size": (4, 5, 6)})["spacing"].tolist()
    [1.0, 1.0, 1.0]
    """
    size, spacing, origin, direction = _grid_of(reference)
    return {"size": tuple(size), "spacing": spacing, "origin": origin, "direction": direction}


def _first_line(exc: BaseException) -> str:
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    return lines[-1][:200] if lines else type(exc).__name__


def _deformer(deformation: Any) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
    if hasattr(deformation, "deform"):
        return deformation.deform
    if callable(deformation):
        return deformation
    raise TypeError(f"expected a deformation (an object with deform(points), or a callable), got "
                    f"{type(deformation).__name__}")  # fmt: skip


def sample_displacement_field(deformation: Any, reference: Any) -> DisplacementField:
    """A deformation sampled at the voxel centres of a reference grid: ``T(x) - x``.

    ``deformation`` is anything with ``deform(points)`` (an :class:`~ffd_notebook.FFD`, an
    :class:`~ffd_notebook.io.ElastixTransform`, a field) or a callable on ``(N, 3)`` points;
    ``reference`` an image file, a SimpleITK image, a :class:`DisplacementField` or a mapping
    ``{"size": (nx, ny, nz), "spacing": ..., "origin": ..., "direction": ...}``.

    Parameters
    ----------
    deformation : FFD, ElastixTransform, DisplacementField or callable
        What moves points (a callable maps ``(N, 3)`` points to moved points).
    reference : image, DisplacementField or mapping
        The grid: a SimpleITK image or image file, a field, or a mapping with ``size`` and optionally
        ``spacing``, ``origin``, ``direction``.

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
    """
    size, spacing, origin, direction = _grid_of(reference)
    if min(size) < 1 or int(np.prod(size)) > _MAX_VOXELS:
        raise ValueError(f"a reference grid of {size} voxels: expected 1 to {_MAX_VOXELS} voxels")
    grid = DisplacementField(np.zeros((1, 1, 1, 3)), spacing, origin, direction)
    nx, ny, nz = size
    placement = direction * spacing
    fast = _aligned_ffd(deformation, cast("tuple[int, int, int]", tuple(size)), grid)
    if fast is not None:
        return DisplacementField(fast, grid.spacing, grid.origin, grid.direction)
    deform = _deformer(deformation)
    vectors = np.empty((nx, ny, nz, 3))
    per_slab = max(1, _SLAB_POINTS // (ny * nz))
    jk = np.stack(np.meshgrid(np.arange(ny, dtype=np.float64), np.arange(nz, dtype=np.float64), indexing="ij"), -1)
    plane = jk.reshape(-1, 2) @ placement[:, 1:].T + origin  # the voxel centres of the i = 0 layer
    for start in range(0, nx, per_slab):
        stop = min(nx, start + per_slab)
        rows = np.arange(start, stop, dtype=np.float64)[:, None, None] * placement[:, 0]
        points = (plane[None] + rows).reshape(-1, 3)
        moved = np.asarray(deform(points), dtype=np.float64)
        vectors[start:stop] = (moved - points).reshape(stop - start, ny, nz, 3)
    return DisplacementField(vectors, grid.spacing, grid.origin, grid.direction)


def _aligned_ffd(deformation: Any, size: tuple[int, int, int], grid: DisplacementField) -> NDArray | None:
    """An FFD's displacement on a grid along its lattice axes, axis by axis (see :mod:`.tensor_grid`), or ``None``."""
    if not isinstance(deformation, FFD) or deformation.basis != "bspline" or deformation.border != "zero":
        return None
    lat = deformation.lattice
    if not np.allclose(grid.direction, lat.rotation, rtol=0, atol=1e-12):
        return None
    start = lat.to_lattice(grid.origin[None])[0]
    step = (np.diag(lat.rotation.T @ grid.direction) * grid.spacing) / lat.spacing
    local = lat.offsets
    for axis in range(3):
        u = start[axis] + np.arange(size[axis]) * step[axis]
        weights = axis_weights(u, lat.shape[axis])
        if deformation.only_inside:  # the domain is a box: a sample outside it on any axis gets nothing
            weights[(u < 1.0) | (u > lat.shape[axis] - 2.0)] = 0.0
        local = apply_along(weights, local, axis)
    linear = deformation.affine[:3, :3] - np.eye(3)
    if linear.any() or deformation.affine[:3, 3].any():
        placement = grid.direction * grid.spacing
        local = local + (linear @ grid.origin + deformation.affine[:3, 3])
        for axis in range(3):
            shape = [1, 1, 1, 3]
            shape[axis] = size[axis]
            local += (np.arange(size[axis], dtype=np.float64)[:, None] * (linear @ placement[:, axis])).reshape(shape)
    return np.ascontiguousarray(local)


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
    elif isinstance(deformation, DisplacementField) and _same_grid(deformation, reference):
        field = deformation
    else:
        field = sample_displacement_field(deformation, reference)
    image = sitk.GetImageFromArray(np.ascontiguousarray(field.vectors.transpose(2, 1, 0, 3)), isVector=True)
    image.SetSpacing(field.spacing.tolist())
    image.SetOrigin(field.origin.tolist())
    image.SetDirection(field.direction.ravel().tolist())
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


def _same_grid(field: DisplacementField, reference: Any) -> bool:
    size, spacing, origin, direction = _grid_of(reference)
    return (tuple(size) == field.shape and np.array_equal(spacing, field.spacing)
            and np.array_equal(origin, field.origin) and np.array_equal(direction, field.direction))  # fmt: skip


def load_displacement_field(path: str | os.PathLike[str]) -> DisplacementField:
    """Read a displacement field file (``.nii``, ``.nii.gz``, ``.nrrd``, ``.mha``) with SimpleITK.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.nii``, ``.nii.gz``, ``.nrrd`` or ``.mha`` file of 3-vectors.

    Returns
    -------
    DisplacementField
        The field, in ITK's convention.

    Raises
    ------
    FileFormatError
        Not an image SimpleITK reads, not 3D, not 3 components per voxel, too large, or
        non-finite values; names the file.

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
    """
    import SimpleITK as sitk

    _check_suffix(path)
    check_regular_file(path)
    reader = sitk.ImageFileReader()
    reader.SetFileName(os.fspath(path))
    reader.SetImageIO(FIELD_SUFFIXES[field_suffix(path)])  # type: ignore[index]
    try:
        reader.ReadImageInformation()
        dims, components = reader.GetDimension(), reader.GetNumberOfComponents()
        size = tuple(reader.GetSize())
        if dims != 3 or components != 3:
            raise FileFormatError(path, None, f"expected a 3D image of 3-vectors (a displacement field), got "
                                  f"{dims}D with {components} component(s) per voxel")  # fmt: skip
        if int(np.prod(size)) > _MAX_VOXELS:
            raise FileFormatError(path, None, f"a field of {size} voxels is larger than the limit ({_MAX_VOXELS})")
        reader.SetOutputPixelType(sitk.sitkVectorFloat64)
        image = reader.Execute()
    except RuntimeError as exc:
        raise FileFormatError(path, None, f"not a displacement field SimpleITK can read: {_first_line(exc)}") from None
    vectors = sitk.GetArrayFromImage(image).transpose(2, 1, 0, 3)
    try:
        return DisplacementField(vectors, image.GetSpacing(), image.GetOrigin(),
                                 np.array(image.GetDirection()).reshape(3, 3))  # fmt: skip
    except ValueError as exc:
        raise FileFormatError(path, None, str(exc)) from None
