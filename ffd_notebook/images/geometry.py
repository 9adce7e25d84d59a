"""Where an image's voxels are: the regular grid of an image in physical space (ITK's geometry).

Voxel ``(i, j, k)`` of an image sits at ``origin + direction @ (spacing * (i, j, k))``: ITK's and
SimpleITK's convention (``TransformIndexToPhysicalPoint``), with ``size``, ``spacing`` and
``origin`` listed in the order of the index ``(i, j, k)`` (x first). A NumPy array holding the
pixels is indexed the other way round, ``array[k, j, i]`` (``sitk.GetArrayFromImage``'s order,
scikit-image's ``(plane, row, column)``), with the components of a multi-component image (RGB)
on one more, last axis. A 2D image lies in the plane ``z = 0`` of 3D space.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["ImageGrid", "is_sitk_image"]


def is_sitk_image(obj: Any) -> bool:
    """Whether ``obj`` is a ``SimpleITK.Image`` (without importing SimpleITK).

    Examples
    --------
    >>> is_sitk_image(object())
    False
    """
    return type(obj).__name__ == "Image" and type(obj).__module__.split(".")[0] == "SimpleITK"


def _vector(value: ArrayLike | None, dim: int, name: str, default: float) -> NDArray[np.float64]:
    out = np.full(dim, default, dtype=np.float64) if value is None else np.array(value, dtype=np.float64).reshape(-1)
    if out.size == 1 and dim > 1:
        out = np.full(dim, out[0])
    if out.shape != (dim,) or not np.isfinite(out).all():
        raise ValueError(f"{name} must be {dim} finite numbers for a {dim}D image, got {value!r}")
    return out


@dataclass(frozen=True)
class ImageGrid:
    """The voxel grid of a 2D or 3D image: ``size``, ``spacing``, ``origin``, ``direction`` (ITK's meaning).

    Parameters
    ----------
    size : tuple of int
        Voxels along ``i, j[, k]`` (x first, as ``sitk.Image.GetSize()``; the NumPy array's
        shape is this reversed).
    spacing : float or array_like, optional
        Distance between voxel centres along each index axis (positive); 1 by default.
    origin : array_like, optional
        Physical position of voxel ``(0, 0[, 0])``; zeros by default.
    direction : array_like, optional
        ``dim x dim`` matrix whose columns are the index axes in physical space (identity by
        default); any invertible matrix, as in ITK (normally a rotation).

    Examples
    --------
    >>> grid = ImageGrid((4, 3, 2), spacing=(1.0, 2.0, 3.0), origin=(10, 0, 0))
    >>> grid.shape, grid.dim
    ((2, 3, 4), 3)
    >>> grid.physical_points()[-1].tolist()      # voxel (3, 2, 1): the last point, x fastest
    [13.0, 4.0, 3.0]
    """

    size: tuple[int, ...]
    spacing: NDArray[np.float64]
    origin: NDArray[np.float64]
    direction: NDArray[np.float64]

    def __init__(
        self,
        size: ArrayLike,
        spacing: ArrayLike | None = None,
        origin: ArrayLike | None = None,
        direction: ArrayLike | None = None,
    ) -> None:
        size_t = tuple(int(n) for n in np.asarray(size).reshape(-1))
        dim = len(size_t)
        if dim not in (2, 3) or min(size_t) < 1:
            raise ValueError(f"an image grid has 2 or 3 axes of at least one voxel, got size {size!r}")
        spacing_v = _vector(spacing, dim, "spacing", 1.0)
        if (spacing_v <= 0).any():
            raise ValueError(f"spacing must be positive, got {spacing!r}")
        origin_v = _vector(origin, dim, "origin", 0.0)
        direction_m = np.eye(dim) if direction is None else np.array(direction, dtype=np.float64)
        if direction_m.size == dim * dim:
            direction_m = direction_m.reshape(dim, dim)
        if (
            direction_m.shape != (dim, dim)
            or not np.isfinite(direction_m).all()
            or abs(np.linalg.det(direction_m)) < 1e-8
        ):
            raise ValueError(f"direction must be an invertible {dim}x{dim} matrix, got {direction!r}")
        for name, value in (("size", size_t), ("spacing", spacing_v), ("origin", origin_v), ("direction", direction_m)):
            if isinstance(value, np.ndarray):
                value.flags.writeable = False
            object.__setattr__(self, name, value)
        with np.errstate(over="ignore", invalid="ignore"):
            finite = np.isfinite(self.bounds()).all() and np.isfinite(self.physical_to_index()).all()
        if not finite:
            raise ValueError(f"the image's extent is not finite (spacing {spacing!r}, origin {origin!r})")

    @classmethod
    def of(cls, image: Any) -> ImageGrid:
        """The grid of a ``SimpleITK.Image`` (or an ``ImageGrid`` itself).

        For any form of reference (a file, a field, a mapping...) see :func:`~ffd_notebook.images.reference_grid`.

        Parameters
        ----------
        image : SimpleITK.Image or ImageGrid
            An image, 2D or 3D.

        Returns
        -------
        ImageGrid
            Its size, spacing, origin and direction.

        Raises
        ------
        TypeError
            For anything else.

        Examples
        --------
        >>> import SimpleITK as sitk
        >>> ImageGrid.of(sitk.Image(5, 4, sitk.sitkUInt8)).size
        (5, 4)
        """
        if isinstance(image, ImageGrid):
            return image
        if is_sitk_image(image):
            return cls(image.GetSize(), image.GetSpacing(), image.GetOrigin(), image.GetDirection())
        raise TypeError(f"expected a SimpleITK image or an ImageGrid, got {type(image).__name__}")

    # ------------------------------------------------------------------ derived
    @property
    def dim(self) -> int:
        """2 or 3."""
        return len(self.size)

    @property
    def shape(self) -> tuple[int, ...]:
        """The NumPy array's shape (``size`` reversed, without components)."""
        return self.size[::-1]

    def index_to_physical(self) -> NDArray[np.float64]:
        """``4 x 4`` matrix taking ``(i, j, k, 1)`` to ``(x, y, z, 1)`` (a 2D grid in the plane ``z = 0``).

        Returns
        -------
        numpy.ndarray
            The affine matrix ``[direction * spacing, origin; 0, 1]``.

        Examples
        --------
        >>> grid = ImageGrid((4, 3), spacing=(0.5, 2.0), origin=(10, 20))
        >>> grid.index_to_physical().tolist()
        [[0.5, 0.0, 0.0, 10.0], [0.0, 2.0, 0.0, 20.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
        >>> (grid.index_to_physical() @ (3, 2, 0, 1)).tolist()   # voxel (3, 2)
        [11.5, 24.0, 0.0, 1.0]
        """
        m = np.eye(4)
        d = self.dim
        m[:d, :d] = self.direction * self.spacing
        m[:d, 3] = self.origin
        return m

    def physical_to_index(self) -> NDArray[np.float64]:
        """``4 x 4`` matrix taking ``(x, y, z, 1)`` to continuous indices ``(i, j, k, 1)``.

        Returns
        -------
        numpy.ndarray
            The inverse of :meth:`index_to_physical`.

        Examples
        --------
        >>> grid = ImageGrid((4, 3, 2), spacing=2.0, origin=(10, 0, 0), direction=[[0, -1, 0], [1, 0, 0], [0, 0, 1]])
        >>> (grid.physical_to_index() @ (6, 4, 2, 1)).round(6).tolist()    # the centre of voxel (2, 2, 1)
        [2.0, 2.0, 1.0, 1.0]
        >>> (grid.physical_to_index() @ (5, 4, 2, 1)).round(6).tolist()    # between voxels: continuous indices
        [2.0, 2.5, 1.0, 1.0]
        """
        return cast("NDArray[np.float64]", np.linalg.inv(self.index_to_physical()))

    def physical_points(self) -> NDArray[np.float64]:
        """``(N, 3)`` physical positions of every voxel centre, ``i`` fastest (the array's C order).

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` float64, ``N = prod(size)``; ``z = 0`` for a 2D grid.

        Examples
        --------
        >>> ImageGrid((3, 2), spacing=(1.0, 0.5), origin=(0, 10)).physical_points().tolist()
        [[0.0, 10.0, 0.0], [1.0, 10.0, 0.0], [2.0, 10.0, 0.0], [0.0, 10.5, 0.0], [1.0, 10.5, 0.0], [2.0, 10.5, 0.0]]
        """
        axes = [np.arange(n, dtype=np.float64) for n in self.size] + [np.zeros(1)] * (3 - self.dim)
        k, j, i = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
        index = np.stack([i.ravel(), j.ravel(), k.ravel(), np.ones(i.size)])
        return np.ascontiguousarray((self.index_to_physical() @ index)[:3].T)

    def bounds(self) -> NDArray[np.float64]:
        """``(2, 3)`` lower and upper physical corners of the box through the corner voxel centres.

        Returns
        -------
        numpy.ndarray
            ``[[xmin, ymin, zmin], [xmax, ymax, zmax]]`` (``z`` 0 for a 2D grid).

        Examples
        --------
        >>> ImageGrid((5, 3, 2), spacing=(1.0, 2.0, 3.0), origin=(10, 0, 0)).bounds().tolist()
        [[10.0, 0.0, 0.0], [14.0, 4.0, 3.0]]
        >>> ImageGrid((5, 3), direction=[[0, -1], [1, 0]]).bounds().tolist()   # rotated a quarter turn
        [[-2.0, 0.0, 0.0], [0.0, 4.0, 0.0]]
        """
        corners = np.array(np.meshgrid(*[[0.0, n - 1.0] for n in self.size], indexing="ij")).reshape(self.dim, -1)
        corners = np.vstack([corners, np.zeros((3 - self.dim, corners.shape[1])), np.ones(corners.shape[1])])
        pts = (self.index_to_physical() @ corners)[:3]
        return np.stack([pts.min(axis=1), pts.max(axis=1)])

    def to_sitk(self, image: Any) -> Any:
        """Put this grid's spacing, origin and direction on a ``SimpleITK.Image`` of the same size (in place).

        Parameters
        ----------
        image : SimpleITK.Image
            An image of this grid's size.

        Returns
        -------
        SimpleITK.Image
            ``image`` itself, its geometry now this grid's.

        Raises
        ------
        ValueError
            If the image's size is not the grid's.

        Examples
        --------
        >>> import SimpleITK as sitk
        >>> grid = ImageGrid((4, 3), spacing=(0.5, 2.0), origin=(10, 20))
        >>> image = grid.to_sitk(sitk.Image(4, 3, sitk.sitkFloat32))
        >>> image.GetSpacing(), image.GetOrigin(), ImageGrid.of(image) == grid
        ((0.5, 2.0), (10.0, 20.0), True)
        """
        if tuple(image.GetSize()) != self.size:
            raise ValueError(f"image size {image.GetSize()} is not the grid's {self.size}")
        image.SetSpacing(tuple(self.spacing.tolist()))
        image.SetOrigin(tuple(self.origin.tolist()))
        image.SetDirection(tuple(self.direction.ravel().tolist()))
        return image

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ImageGrid):
            return NotImplemented
        return (
            self.size == other.size
            and np.array_equal(self.spacing, other.spacing)
            and np.array_equal(self.origin, other.origin)
            and np.array_equal(self.direction, other.direction)
        )

    __hash__ = None  # type: ignore[assignment]  # arrays inside: equal grids need not hash alike

    def __repr__(self) -> str:
        def fmt(v: NDArray[np.float64]) -> str:
            return "(" + ", ".join(f"{x:g}" for x in np.ravel(v)) + ")"

        geometry = f"spacing={fmt(self.spacing)}, origin={fmt(self.origin)}, direction={fmt(self.direction)}"
        return f"ImageGrid(size={self.size}, {geometry})"
