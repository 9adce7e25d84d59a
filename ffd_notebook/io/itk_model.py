"""An FFD as ITK transforms and back: the part of ITK's transform files that is not syntax.

What ITK computes (``itkBSplineTransform.hxx``, checked against SimpleITK):

- ``BSplineTransform_double_3_3`` (order 3) keeps a grid of coefficients, the control points.
  Fixed parameters: grid size ``(nx, ny, nz)``, grid origin (the position of control point
  (0, 0, 0)), grid spacing, and the grid direction as a 3x3 matrix written row by row whose
  columns are the grid axes (a reflection is allowed). So a :class:`~ffd_notebook.Lattice` is the
  grid with ``origin``, ``spacing`` and ``rotation`` as they are. Parameters: all x components,
  then all y, then all z; within a component x varies fastest, then y, then z.
- The displacement is the cubic B-spline sum of ``docs/ffd-format.md``, but only inside the
  transform domain ``1 <= u <= n - 2`` (lattice coordinates): elsewhere ITK leaves the point
  where it is. A lattice whose deformation reaches further (the "zero" border: supports that
  overlap the lattice partly still move points) is written with three more layers of zero control
  points on every side, which makes ITK's domain cover everything the lattice moves; a grid read
  with three zero layers all round is read back as the smaller lattice. Any other grid is read as
  ``FFD(..., only_inside=True)``.
- A ``CompositeTransform`` applies its children last first: ``T(x) = T_1(T_2(... T_k(x)))``.
  ``A x + b + T_local(x)`` is written as the composite of ``AffineTransform(A, b)`` after a
  B-spline with coefficients ``A^-1 offsets``: ``A (x + A^-1 T_local(x)) + b``.
- A grid direction that is orthogonal only to float32 precision (SimpleITK's
  ``BSplineTransformInitializer`` on a rotated image writes such) is replaced by the nearest
  rotation: the FFD then differs from ITK by about 1e-7 of the coordinates. A direction further
  from orthogonal (a sheared grid) is refused.
- ``AffineTransform``: parameters are the matrix row by row and the translation; the fixed
  parameters are the centre ``c``: ``x -> M (x - c) + c + t``.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import FileFormatError
from ..ffd.deform import FFD
from ..ffd.lattice import Lattice, nearest_rotation, orthogonality_error
from ..ffd.support import pad_offsets
from .displacement_field import DisplacementField
from .transform_chain import AffineTransform, TransformChain

__all__ = [
    "RawTransform",
    "deformation_to_transforms",
    "ffd_to_transforms",
    "strip_padding",
    "transforms_to_deformation",
    "transforms_to_ffd",
]

ITK_BSPLINE_TRANSFORM = "BSplineTransform_double_3_3"
AFFINE = "AffineTransform_double_3_3"
COMPOSITE = "CompositeTransform_double_3_3"
_AFFINE_LIKE = ("AffineTransform", "MatrixOffsetTransformBase")
_KNOWN = ("BSplineTransform", "TranslationTransform", "CompositeTransform", *_AFFINE_LIKE)
_FIELD = "DisplacementFieldTransform"
_KIND = re.compile(r"([A-Za-z0-9]+)_(double|float)_(\d+)_(\d+)")
_PAD = 3  # zero layers that make ITK's domain cover a zero-border lattice's whole reach
_MAX_AXIS = 4096


@dataclass
class RawTransform:
    """One transform of a file: ITK type name, parameters, fixed parameters, where each was read.

    ``where`` maps ``"kind"``, ``"parameters"`` and ``"fixed"`` to a line number (text files), an HDF5
    dataset's path (``/TransformGroup/...``) or a MATLAB matrix (``matrix 'AffineTransform_double_3_3'``), for
    error messages.
    """

    kind: str
    parameters: np.ndarray
    fixed: np.ndarray
    where: dict[str, int | str] = field(default_factory=dict)


def _error(path: str | os.PathLike[str], raw: RawTransform, key: str, problem: str) -> FileFormatError:
    where = raw.where.get(key)
    if isinstance(where, str):  # an HDF5 dataset's path, or a MATLAB matrix named as such
        return FileFormatError(path, None, f"{'HDF5 dataset ' if where.startswith('/') else ''}{where}: {problem}")
    return FileFormatError(path, where, problem)


def _base(path: str | os.PathLike[str], raw: RawTransform) -> str:
    match = _KIND.fullmatch(raw.kind)
    if match is None or match.group(3, 4) != ("3", "3"):
        raise _error(path, raw, "kind", f"unsupported transform type {raw.kind!r}; expected a 3D "
                     "BSplineTransform, AffineTransform or CompositeTransform (_double_3_3)")  # fmt: skip
    return match.group(1)


# ---------------------------------------------------------------------------------------- reading
def _affine_of(path: str | os.PathLike[str], raw: RawTransform, base: str) -> tuple[np.ndarray, np.ndarray]:
    """``(A, b)`` of an affine-like transform (``x -> A x + b``)."""
    p, fixed = raw.parameters, raw.fixed
    if base == "TranslationTransform":
        if len(p) != 3:
            raise _error(path, raw, "parameters", f"a TranslationTransform has 3 parameters, got {len(p)}")
        return np.eye(3), p.copy()
    if base not in _AFFINE_LIKE:
        raise _error(path, raw, "kind", f"unsupported transform type {raw.kind!r}; a B-spline can be combined "
                     "with AffineTransform, MatrixOffsetTransformBase or TranslationTransform only")  # fmt: skip
    if len(p) != 12:
        raise _error(path, raw, "parameters", f"an {base} has 12 parameters (matrix, translation), got {len(p)}")
    if len(fixed) not in (0, 3):
        raise _error(path, raw, "fixed", f"an {base} has 3 fixed parameters (the centre), got {len(fixed)}")
    matrix, translation = p[:9].reshape(3, 3), p[9:]
    center = fixed if len(fixed) else np.zeros(3)
    return matrix, translation + center - matrix @ center


def _grid(path: str | os.PathLike[str], raw: RawTransform) -> tuple[Lattice, np.ndarray]:
    """The B-spline's grid as a lattice with zero offsets, and its coefficients ``(nx, ny, nz, 3)``."""
    fixed = raw.fixed
    if len(fixed) != 18:
        raise _error(path, raw, "fixed", f"a 3D BSplineTransform has 18 fixed parameters (size, origin, spacing, "
                     f"direction), got {len(fixed)}")  # fmt: skip
    size = fixed[:3]
    if np.any(size != np.round(size)) or np.any(size < 4) or np.any(size > _MAX_AXIS):
        raise _error(path, raw, "fixed", f"expected a grid size of integers in 4..{_MAX_AXIS} (a cubic B-spline "
                     f"needs 4 control points per axis), got {size.tolist()}")  # fmt: skip
    shape = tuple(int(n) for n in size)
    spacing, origin, direction = fixed[6:9], fixed[3:6], fixed[9:].reshape(3, 3)
    if np.any(spacing <= 0):
        raise _error(path, raw, "fixed", f"expected a positive grid spacing, got {spacing.tolist()}")
    rotation = nearest_rotation(direction)  # float32-rounded directions: the rotation they round
    if rotation is None:
        raise _error(path, raw, "fixed", f"the grid direction is not orthogonal (off by "
                     f"{orthogonality_error(direction):.2g}: a sheared grid); a lattice's rotation must be, so this "
                     "transform cannot be read exactly")  # fmt: skip
    n = int(np.prod(shape))
    if len(raw.parameters) != 3 * n:
        raise _error(path, raw, "parameters", f"a {shape[0]}x{shape[1]}x{shape[2]} grid has {3 * n} parameters, "
                     f"got {len(raw.parameters)}")  # fmt: skip
    coefficients = raw.parameters.reshape(3, shape[2], shape[1], shape[0]).transpose(3, 2, 1, 0)
    return Lattice(shape, spacing, origin, rotation), coefficients


def _compose(pairs: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """``T_1 o T_2 o ... o T_k`` of affine maps given as ``(A, b)``."""
    a, b = np.eye(3), np.zeros(3)
    for a_t, b_t in reversed(pairs):
        a, b = a_t @ a, a_t @ b + b_t
    return a, b


def _pull_back(path, raw: RawTransform, lattice: Lattice, a: np.ndarray, b: np.ndarray) -> Lattice:
    """The lattice ``L'`` with ``L'.to_lattice(x) == lattice.to_lattice(a x + b)``, if there is one."""
    if np.array_equal(a, np.eye(3)):
        return Lattice(lattice.shape, lattice.spacing, lattice.origin - b, lattice.rotation)
    columns = a.T @ lattice.rotation / lattice.spacing  # must be R' / spacing' for a lattice R', spacing'
    spacing = 1.0 / np.linalg.norm(columns, axis=0)
    rotation = nearest_rotation(columns * spacing)
    if rotation is None:
        raise _error(path, raw, "kind", "the affine applied before the B-spline shears its grid; an FFD "
                     "(affine after the lattice) cannot hold that exactly")  # fmt: skip
    origin = np.linalg.solve(a, lattice.origin - b)
    return Lattice(lattice.shape, spacing, origin, rotation)


def strip_padding(lattice: Lattice) -> Lattice | None:
    """The lattice without three zero layers all round, if it has them (what the writer adds)."""
    if min(lattice.shape) < 4 + 2 * _PAD:
        return None
    inner = lattice.offsets[_PAD:-_PAD, _PAD:-_PAD, _PAD:-_PAD]
    if np.count_nonzero(lattice.offsets) != np.count_nonzero(inner):
        return None
    origin = lattice.origin + lattice.rotation @ (_PAD * lattice.spacing)
    return Lattice(inner.shape[:3], lattice.spacing, origin, lattice.rotation, inner)


def _children(path: str | os.PathLike[str], transforms: list[RawTransform]) -> list[RawTransform]:
    """A file's transforms without their CompositeTransform: what it composes (or the one transform)."""
    first = transforms[0]
    if _base(path, first) == "CompositeTransform":
        if len(transforms) == 1:
            raise _error(path, first, "kind", "an empty CompositeTransform")
        return transforms[1:]
    if len(transforms) > 1:
        raise _error(path, transforms[1], "kind", f"{len(transforms)} transforms side by side; expected one "
                     "(several belong in a CompositeTransform)")  # fmt: skip
    return transforms


def transforms_to_ffd(path: str | os.PathLike[str], transforms: list[RawTransform]) -> FFD:
    """The FFD equal to a file's transforms everywhere, or a :class:`FileFormatError` saying why not."""
    first = transforms[0]
    chain = _children(path, transforms)
    bases = [_base(path, raw) for raw in chain]
    for raw, base in zip(chain, bases, strict=True):
        if base not in _KNOWN:
            problem = (f"unsupported transform type {raw.kind!r}; expected a BSplineTransform, alone or in a "
                       "CompositeTransform with AffineTransform or TranslationTransform parts")  # fmt: skip
            raise _error(path, raw, "kind", problem)
    where = [i for i, base in enumerate(bases) if base == "BSplineTransform"]
    if len(where) != 1:
        culprit = chain[where[1]] if where else first
        raise _error(path, culprit, "kind", f"expected exactly one BSplineTransform, found {len(where)}: an FFD "
                     "is one lattice")  # fmt: skip
    j = where[0]
    for raw, base in zip(chain, bases, strict=True):
        if base == "CompositeTransform":
            raise _error(path, raw, "kind", "a CompositeTransform inside a CompositeTransform is not supported")
    outer = _compose([_affine_of(path, raw, base) for raw, base in zip(chain[:j], bases[:j], strict=True)])
    inner = _compose([_affine_of(path, raw, base) for raw, base in zip(chain[j + 1 :], bases[j + 1 :], strict=True)])
    grid, coefficients = _grid(path, chain[j])
    lattice = _pull_back(path, chain[j], grid, *inner)
    a_out, b_out = outer
    lattice.offsets[...] = coefficients @ a_out.T
    affine = np.eye(4)
    affine[:3, :3] = a_out @ inner[0]
    affine[:3, 3] = a_out @ inner[1] + b_out
    if not np.all(np.isfinite(affine)) or not np.all(np.isfinite(lattice.offsets)):
        raise _error(path, chain[j], "parameters", "the combined transform overflows (infinite values)")
    stripped = strip_padding(lattice)
    if stripped is not None:
        return FFD(stripped, "bspline", affine=affine)
    return FFD(lattice, "bspline", affine=affine, only_inside=True)


def _field(path: str | os.PathLike[str], raw: RawTransform) -> DisplacementField:
    """A ``DisplacementFieldTransform``: fixed parameters size, origin, spacing, direction (row by row); parameters
    the vectors, interleaved, x fastest (ITK's image buffer order)."""
    fixed = raw.fixed
    if len(fixed) != 18:
        raise _error(path, raw, "fixed", f"a 3D DisplacementFieldTransform has 18 fixed parameters (size, origin, "
                     f"spacing, direction), got {len(fixed)}")  # fmt: skip
    size = fixed[:3]
    if np.any(size != np.round(size)) or np.any(size < 1) or np.prod(size) * 3 != len(raw.parameters):
        raise _error(path, raw, "parameters", f"a field of size {size.tolist()} has 3 values per voxel, got "
                     f"{len(raw.parameters)} parameters")  # fmt: skip
    nx, ny, nz = (int(n) for n in size)
    vectors = raw.parameters.reshape(nz, ny, nx, 3)  # SimpleITK's array order, as DisplacementField keeps it
    try:
        return DisplacementField(vectors, fixed[6:9], fixed[3:6], fixed[9:].reshape(3, 3))
    except ValueError as exc:
        raise _error(path, raw, "fixed", str(exc)) from None


def transforms_to_deformation(
    path: str | os.PathLike[str], transforms: list[RawTransform]
) -> FFD | AffineTransform | TransformChain:
    """What a file's transforms mean: an FFD (one B-spline with affine parts, :func:`transforms_to_ffd`), an
    :class:`AffineTransform` (affine parts only) or a :class:`TransformChain` (displacement fields among them, as in
    ANTs' composite files; the chain lists them in the order they move a point, the composite's last child first).
    """
    children = _children(path, transforms)
    bases = [_base(path, raw) for raw in children]
    if _FIELD not in bases:
        if "BSplineTransform" in bases or "CompositeTransform" in bases:
            return transforms_to_ffd(path, transforms)
        parts = [_affine_of(path, raw, base) for raw, base in zip(children, bases, strict=True)]
        return AffineTransform(_homogeneous(*_compose(parts)))
    steps: list[Any] = []
    for raw, base in zip(reversed(children), reversed(bases), strict=True):
        if base == _FIELD:
            steps.append(_field(path, raw))
        elif base == "BSplineTransform":
            steps.append(transforms_to_ffd(path, [raw]))
        elif base == "CompositeTransform":
            raise _error(path, raw, "kind", "a CompositeTransform inside a CompositeTransform is not supported")
        else:
            matrix = _homogeneous(*_affine_of(path, raw, base))
            if steps and isinstance(steps[-1], AffineTransform):  # consecutive affine parts: one map
                matrix = matrix @ steps.pop().matrix
            steps.append(AffineTransform(matrix))
    return TransformChain(steps)


def _homogeneous(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    matrix = np.eye(4)
    matrix[:3, :3], matrix[:3, 3] = a, b
    return matrix


# ---------------------------------------------------------------------------------------- writing
def _check_writable(ffd: FFD) -> None:
    if not isinstance(ffd, FFD):
        raise TypeError(f"expected an FFD, got {type(ffd).__name__}")
    if ffd.basis != "bspline":
        raise ValueError(f"an FFD with the {ffd.basis!r} basis has no ITK transform: only the cubic B-spline "
                         "basis (BSplineTransform) can be written exactly")  # fmt: skip
    if ffd.weights is not None:
        raise ValueError("an FFD with per-point weights has no ITK transform: a transform moves every point of "
                         "space the same way, whatever mesh it belongs to")  # fmt: skip
    border = ffd.border
    if border != "zero":
        raise ValueError(f"an FFD with border={border!r} has no ITK transform: ITK's BSplineTransform treats "
                         "control points outside the grid as zero (border='zero')")  # fmt: skip
    if ffd.lattice.sheared:
        raise ValueError("the lattice is sheared (its axes are not orthogonal): ITK's BSplineTransform grid is "
                         "read back only with an orthogonal direction here; write it as an elastix file")  # fmt: skip


def ffd_to_transforms(ffd: FFD) -> list[RawTransform]:
    """ITK transforms equal to ``ffd.deform`` everywhere (to rounding); refuses what ITK cannot hold.

    Examples
    --------
    >>> from ffd_notebook import FFD, Lattice
    >>> [t.kind for t in ffd_to_transforms(FFD(Lattice((4, 4, 4), 1.0)))]
    ['BSplineTransform_double_3_3']
    >>> ffd_to_transforms(FFD(Lattice((4, 4, 4), 1.0), "bernstein"))
    Traceback (most recent call last):
    ...
    ValueError: an FFD with the 'bernstein' basis has no ITK transform: ...
    """
    _check_writable(ffd)
    ffd = ffd.baked()  # a strength and "outside" mode are the offsets and affine part they give
    lat = ffd.lattice
    offsets, origin, shape = lat.offsets, lat.origin, lat.shape
    if not ffd.only_inside:
        offsets = pad_offsets(offsets, "zero", _PAD)
        origin = origin - lat.rotation @ (_PAD * lat.spacing)
        shape = offsets.shape[:3]
    a, b = ffd.affine[:3, :3], ffd.affine[:3, 3]
    plain = np.array_equal(a, np.eye(3))
    if not plain:
        if np.linalg.cond(a) > 1e12:
            raise ValueError("the FFD's affine matrix is singular: the B-spline coefficients A^-1 offsets of the "
                             "ITK composite (affine after B-spline) do not exist")  # fmt: skip
        offsets = offsets @ np.linalg.inv(a).T
    fixed = np.concatenate([np.asarray(shape, dtype=np.float64), origin, lat.spacing, lat.rotation.ravel()])
    bspline = RawTransform(ITK_BSPLINE_TRANSFORM, np.ascontiguousarray(offsets.transpose(3, 2, 1, 0)).ravel(), fixed)
    if plain and not b.any():
        return [bspline]
    affine = RawTransform(AFFINE, np.concatenate([a.ravel(), b]), np.zeros(3))
    return [RawTransform(COMPOSITE, np.zeros(0), np.zeros(0)), affine, bspline]


def _field_transform(field: DisplacementField) -> RawTransform:
    fixed = np.concatenate([np.asarray(field.size, dtype=np.float64), field.origin, field.spacing,
                            field.direction.ravel()])  # fmt: skip
    vectors = np.ascontiguousarray(field.vectors).ravel()
    return RawTransform(_FIELD + "_double_3_3", vectors, fixed)


def deformation_to_transforms(deformation: Any) -> list[RawTransform]:
    """ITK transforms equal to an FFD, an :class:`AffineTransform`, a displacement field or a
    :class:`TransformChain` of them (a ``CompositeTransform`` for a chain); refuses what ITK cannot hold.

    Examples
    --------
    >>> from ffd_notebook import FFD, Lattice
    >>> chain = TransformChain([FFD(Lattice((4, 4, 4), 1.0)), AffineTransform(np.diag([2.0, 1.0, 1.0, 1.0]))])
    >>> [t.kind for t in deformation_to_transforms(chain)]
    ['CompositeTransform_double_3_3', 'AffineTransform_double_3_3', 'BSplineTransform_double_3_3']
    """
    if isinstance(deformation, FFD):
        return ffd_to_transforms(deformation)
    if isinstance(deformation, AffineTransform):
        return [RawTransform(AFFINE, np.concatenate([deformation.matrix[:3, :3].ravel(), deformation.matrix[:3, 3]]),
                             np.zeros(3))]  # fmt: skip
    if isinstance(deformation, DisplacementField):
        if deformation.outside != "zero":
            raise ValueError("this displacement field moves points beyond its grid (NiftyReg's rule); ITK's "
                             "DisplacementFieldTransform leaves them where they are")  # fmt: skip
        return [_field_transform(deformation)]
    if isinstance(deformation, TransformChain):
        children: list[RawTransform] = []
        for step in reversed(deformation.steps):  # a composite's last child moves the point first
            parts = deformation_to_transforms(step)
            children.extend(parts[1:] if parts[0].kind.startswith("CompositeTransform") else parts)
        return [RawTransform(COMPOSITE, np.zeros(0), np.zeros(0)), *children]
    raise TypeError(f"expected an FFD, an AffineTransform, a DisplacementField or a TransformChain, got "
                    f"{type(deformation).__name__}")  # fmt: skip
