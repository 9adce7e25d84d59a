"""Deformations that are not one lattice: an affine map, and a chain of deformations applied one after another.

ANTs writes a registration as several files (``1Warp.nii.gz``, ``0GenericAffine.mat``) that its tools apply as a
list, in ``antsApplyTransforms -t`` order, or as one ITK composite file (``--write-composite-transform``). Checked
against ``ants.apply_transforms`` on a real SyN registration: the list ``[warp, affine]`` moves a point of the
fixed image to ``affine(warp(x))``, the first file of the list moving the point first. An ITK composite holds
the same transforms the other way round (its last child moves the point first, ``itkCompositeTransform.h``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._util.points import as_points

__all__ = ["AffineTransform", "TransformChain"]


class AffineTransform:
    """The affine map ``x -> A x + b`` (an ITK ``AffineTransform``, ANTs' ``GenericAffine.mat``).

    Parameters
    ----------
    matrix : array_like
        4x4 homogeneous matrix (or 3x4 ``[A | b]``), in the physical (LPS) space of ITK.

    Examples
    --------
    >>> t = AffineTransform([[2.0, 0, 0, 1.0], [0, 1, 0, 0], [0, 0, 1, 0]])
    >>> t.deform([[1.0, 1.0, 1.0]]).tolist()
    [[3.0, 1.0, 1.0]]
    """

    def __init__(self, matrix: ArrayLike) -> None:
        m = np.array(matrix, dtype=np.float64)
        if m.shape == (3, 4):
            m = np.vstack([m, [0.0, 0.0, 0.0, 1.0]])
        if m.shape != (4, 4) or not np.array_equal(m[3], [0.0, 0.0, 0.0, 1.0]) or not np.all(np.isfinite(m)):
            raise ValueError("matrix must be a finite 4x4 homogeneous matrix (or 3x4 [A | b])")
        self.matrix: NDArray[np.float64] = m

    def deform(self, points: ArrayLike) -> NDArray[np.float64]:
        """``A x + b`` for ``(N, 3)`` points.

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` moved points.

        Examples
        --------
        >>> AffineTransform(np.eye(4)).deform([[1.0, 2.0, 3.0]]).tolist()
        [[1.0, 2.0, 3.0]]
        """
        pts = as_points(points)
        return pts @ self.matrix[:3, :3].T + self.matrix[:3, 3]

    __call__ = deform

    def inverse(self) -> AffineTransform:
        """The inverse map (``ValueError`` for a singular one).

        Returns
        -------
        AffineTransform

        Examples
        --------
        >>> t = AffineTransform([[2.0, 0, 0, 1.0], [0, 1, 0, 0], [0, 0, 1, 0]])
        >>> t.inverse().deform(t.deform([[1.0, 2.0, 3.0]])).tolist()
        [[1.0, 2.0, 3.0]]
        """
        if np.linalg.cond(self.matrix[:3, :3]) > 1e12:
            raise ValueError("a singular affine transform has no inverse")
        return AffineTransform(np.linalg.inv(self.matrix))

    def __repr__(self) -> str:
        return f"AffineTransform({self.matrix[:3].round(6).tolist()})"


class TransformChain:
    """Deformations applied one after another, the first of the list first (``antsApplyTransforms -t`` order).

    ``TransformChain([warp, affine]).deform(x)`` is ``affine.deform(warp.deform(x))``: what ANTs does with the
    list ``[prefix1Warp.nii.gz, prefix0GenericAffine.mat]`` its registration returns.

    Parameters
    ----------
    steps : sequence
        The deformations: anything with ``deform(points)`` (an FFD, a
        :class:`~ffd_notebook.io.DisplacementField`, an :class:`AffineTransform`...).

    Examples
    --------
    >>> shift = AffineTransform([[1.0, 0, 0, 1.0], [0, 1, 0, 0], [0, 0, 1, 0]])
    >>> double = AffineTransform(np.diag([2.0, 2.0, 2.0, 1.0]))
    >>> TransformChain([shift, double]).deform([[1.0, 1.0, 1.0]]).tolist()     # double(shift(x))
    [[4.0, 2.0, 2.0]]
    """

    def __init__(self, steps: Sequence[Any]) -> None:
        steps = list(steps)
        if not steps:
            raise ValueError("a transform chain needs at least one deformation")
        for step in steps:
            if not callable(getattr(step, "deform", None)):
                raise TypeError(f"every step must have deform(points), got {type(step).__name__}")
        self.steps: list[Any] = steps

    def deform(self, points: ArrayLike) -> NDArray[np.float64]:
        """Move ``(N, 3)`` points through every step, the first step first.

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` moved points.

        Examples
        --------
        >>> TransformChain([AffineTransform(np.eye(4))]).deform([[0.0, 1.0, 2.0]]).tolist()
        [[0.0, 1.0, 2.0]]
        """
        pts = as_points(points)
        for step in self.steps:
            pts = np.asarray(step.deform(pts), dtype=np.float64)
        return pts

    __call__ = deform

    def __len__(self) -> int:
        return len(self.steps)

    def __repr__(self) -> str:
        return f"TransformChain([{', '.join(type(s).__name__ for s in self.steps)}])"
