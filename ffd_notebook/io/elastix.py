"""elastix transform parameter files: chains of transforms read exactly as transformix applies them.

What elastix computes (``elxTransformBase.hxx``, ``elxAdvancedBSplineTransform.hxx``,
``itkAdvancedBSplineDeformableTransform.hxx``, ``itkAdvancedCombinationTransform.hxx``):

- A file holds one transform (``Transform``, ``TransformParameters``) and names the file of the
  transform before it (``InitialTransformParameterFileName``, ``"NoInitialTransform"`` for none).
  ``HowToCombineTransforms "Compose"`` (the default) makes ``T(x) = T1(T0(x))``; any other
  value adds, ``T(x) = T1(x) + T0(x) - x``, where ``T0`` is the whole chain before.
- elastix writes that name as its working directory saw it. It is looked for beside the file
  first, then as written (relative to the working folder: elastix's other rule), then as its last
  part beside the file (results folders get moved); a name found both beside the file and in the
  working folder, as two different files, is refused rather than guessed (a stray file of the
  same name in a notebook's folder was chained silently). A chain that comes back to a file, or
  runs deeper than :data:`MAX_CHAIN`, is refused. Every file of the chain goes through the one
  rule for files a file names (:func:`~ffd_notebook._util.file_access.named_file`): with
  ``within``, the chain stays in that folder, and a name outside it is "not in the folder"
  whether it exists or not.
- ``BSplineTransform`` and ``RecursiveBSplineTransform``: a grid of ``GridSize`` coefficients at
  ``GridOrigin + GridDirection @ (GridSpacing * (GridIndex + ijk))``; ``GridDirection`` is written
  column by column (ITK's fixed parameters write it row by row). ``TransformParameters``: all x
  coefficients, then all y, then all z, x index fastest. A point moves by the cubic B-spline sum
  at its continuous grid index ``u`` only where ``1 <= u < n - 2`` on every axis (the support lies
  in the grid); elsewhere it stays. Orders other than 3 and cyclic grids are refused (the engine
  evaluates cubic B-splines only).
- ``AffineTransform`` (matrix row by row, translation), ``EulerTransform`` (angles about x, y, z in
  radians, translation; ``R = Rz Rx Ry``, or ``Rz Ry Rx`` with ``ComputeZYX "true"``),
  ``SimilarityTransform`` (versor, translation, scale), ``TranslationTransform``: ``x -> M (x - c)
  + c + t`` with ``c`` the ``CenterOfRotationPoint``.

:func:`load_elastix` returns the chain as an :class:`ElastixTransform`, which moves points as
transformix does; :meth:`ElastixTransform.to_ffd` lowers it onto one :class:`~ffd_notebook.FFD`
(what :func:`~ffd_notebook.io.load_deformation` returns). :func:`save_elastix` writes an FFD as a
B-spline file, preceded by an affine file combined by "Add" when the FFD has an affine part:
``A x + b + T_local(x) = Affine(x) + BSpline(x) - x``, this package's own formulation.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._util.file_access import is_inside, named_file, read_bytes
from .._util.points import as_points
from ..ffd import oneshot as _oneshot
from ..ffd.deform import FFD
from ..ffd.lattice import Lattice, nearest_rotation
from ..ffd.support import in_domain
from ..images.geometry import ImageGrid
from .elastix_text import ParameterMap, read_parameter_file, write_parameter_file
from .itk_model import strip_padding

__all__ = ["MAX_CHAIN", "BSplineStep", "ElastixTransform", "LinearStep", "load_elastix", "save_elastix"]

#: Longest chain of files followed through ``InitialTransformParameterFileName``.
MAX_CHAIN = 32
_MAX_AXIS = 4096
_LINEAR = ("AffineTransform", "EulerTransform", "SimilarityTransform", "TranslationTransform")
_BSPLINE = ("BSplineTransform", "RecursiveBSplineTransform")
_PAD = 3  # zero layers that make the valid region cover a zero-border lattice's reach (as for ITK files)
#: The fixed-image keys kept from a loaded file and written back (transformix resamples onto that grid).
GEOMETRY_KEYS = ("Size", "Index", "Spacing", "Origin", "Direction")


# ---------------------------------------------------------------------------------------- steps
@dataclass
class LinearStep:
    """``x -> matrix @ x + offset``, read from one file (``kind`` is the elastix transform name)."""

    kind: str
    matrix: NDArray[np.float64]
    offset: NDArray[np.float64]
    path: str = ""

    def apply(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        return points @ self.matrix.T + self.offset


@dataclass
class BSplineStep:
    """elastix's cubic B-spline: ``x + sum B(u) c`` where ``1 <= u < n - 2``, ``x`` elsewhere.

    ``direction`` and ``spacing`` as in the file (``GridDirection``, columns the grid axes;
    ``GridSpacing``); ``origin`` the position of the first coefficient (``GridOrigin`` moved by
    ``GridIndex``); ``coefficients`` ``(nx, ny, nz, 3)``.
    """

    kind: str
    direction: NDArray[np.float64]
    spacing: NDArray[np.float64]
    origin: NDArray[np.float64]
    coefficients: NDArray[np.float64]
    path: str = ""
    _to_index: NDArray[np.float64] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._to_index = cast("NDArray[np.float64]", np.linalg.inv(self.placement))

    @property
    def placement(self) -> NDArray[np.float64]:
        """``direction @ diag(spacing)``: grid index to world offset."""
        return self.direction * self.spacing

    def grid_index(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """Continuous grid indices of ``(N, 3)`` points as rows ``(3, N)``."""
        return self._to_index @ (points - self.origin).T

    def apply(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        rows = self.grid_index(points)
        valid = in_domain("bspline", self.coefficients.shape[:3], rows.T, "half-open")  # elastix's valid region
        out = points.copy()
        if valid.any():
            inside = np.ascontiguousarray(rows[:, valid])
            out[valid] += _oneshot.bspline_displacement(self.coefficients, inside).T
        return out


ElastixStep = LinearStep | BSplineStep


# ---------------------------------------------------------------------------------------- the chain
class ElastixTransform:
    """A chain of elastix transforms, first (innermost) to last, as transformix applies it.

    Parameters
    ----------
    steps : list of LinearStep or BSplineStep
        The transforms, the initial one first.
    combine : list of str
        How each step after the first joins the chain before it: ``"Compose"`` or ``"Add"``.
    geometry : dict, optional
        The fixed-image keys of the last file (written back by :func:`save_elastix`).

    Examples
    --------
    >>> import numpy as np
    >>> shift = LinearStep("TranslationTransform", np.eye(3), np.array([1.0, 0.0, 0.0]))
    >>> scale = LinearStep("AffineTransform", 2 * np.eye(3), np.zeros(3))
    >>> ElastixTransform([shift, scale], ["Compose"]).deform([[1.0, 1.0, 1.0]]).tolist()
    [[4.0, 2.0, 2.0]]
    >>> ElastixTransform([shift, scale], ["Add"]).deform([[1.0, 1.0, 1.0]]).tolist()
    [[3.0, 2.0, 2.0]]
    """

    def __init__(self, steps: list[ElastixStep], combine: list[str], geometry: dict[str, list[float]] | None = None):
        if not steps or len(combine) != len(steps) - 1 or any(c not in ("Compose", "Add") for c in combine):
            raise ValueError("expected at least one step and 'Compose' or 'Add' for each step after the first")
        self.steps = list(steps)
        self.combine = list(combine)
        self.geometry = dict(geometry or {})

    @property
    def grid(self) -> ImageGrid | None:
        """The fixed image's grid the last file names (``Size``, ``Spacing``, ``Origin``, ``Direction``), or None.

        elastix writes ``Direction`` column by column. A chain with a grid is a reference grid itself
        (:func:`~ffd_notebook.images.reference_grid`): fields and fitted lattices default to it.

        Examples
        --------
        >>> import numpy as np
        >>> step = LinearStep("TranslationTransform", np.eye(3), np.zeros(3))
        >>> geometry = {"Size": [4, 5, 6], "Spacing": [1.0, 1.0, 2.0], "Origin": [0.0, 0.0, 0.0],
        ...             "Direction": [0.0, 1.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 1.0]}
        >>> grid = ElastixTransform([step], [], geometry).grid
        >>> grid.size, grid.direction[:, 0].tolist()      # the first axis runs along +y
        ((4, 5, 6), [0.0, 1.0, 0.0])
        >>> ElastixTransform([step], []).grid is None
        True
        """
        g = self.geometry
        if not all(k in g for k in ("Size", "Spacing", "Origin", "Direction")):
            return None
        return ImageGrid(g["Size"], g["Spacing"], g["Origin"], np.reshape(g["Direction"], (3, 3)).T)

    def deform(self, points: ArrayLike) -> NDArray[np.float64]:
        """Where the chain takes ``(N, 3)`` points (transformix's ``OutputPoint``).

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points in physical coordinates.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` points moved as transformix moves them.

        Examples
        --------
        >>> import pathlib, tempfile
        >>> import numpy as np
        >>> from ffd_notebook import FFD, Lattice
        >>> lat = Lattice((4, 4, 4), 1.0); lat.offsets[1, 1, 1] = (0.3, 0.0, 0.0)
        >>> path = pathlib.Path(tempfile.mkdtemp()) / "TransformParameters.0.txt"
        >>> save_elastix(path, FFD(lat))
        >>> chain = load_elastix(path)
        >>> bool(np.allclose(chain.deform([[1.2, 1.0, 1.1]]), FFD(lat).deform([[1.2, 1.0, 1.1]])))
        True
        """
        x = as_points(points)
        y = self.steps[0].apply(x)
        for step, how in zip(self.steps[1:], self.combine, strict=True):
            y = step.apply(y) if how == "Compose" else y + step.apply(x) - x
        return y

    __call__ = deform

    def to_ffd(self) -> FFD:
        """The one :class:`~ffd_notebook.FFD` equal to this chain everywhere.

        A chain with exactly one B-spline: linear steps composed before it pull its grid back
        (the lattice is placed by the inverse map), any other linear step becomes the FFD's affine
        part (composed after it: the offsets turn with it). ``only_inside="half-open"`` (points outside
        the B-spline's valid region do not move; the region is open at its far faces, as elastix's),
        unless the grid has three zero layers all round (what :func:`save_elastix` writes), which are dropped.

        A linear map with shear composed before the B-spline (elastix's usual affine-then-B-spline
        registration) gives a sheared lattice (:attr:`~ffd_notebook.Lattice.sheared`): elastix
        files hold it, .ffd, ITK and PyGeM files refuse it.

        Returns
        -------
        FFD
            The chain as one FFD: its B-spline's lattice (placed by the linear steps before it) and an affine part.

        Raises
        ------
        ValueError
            No B-spline or two of them (an FFD is one lattice).

        Examples
        --------
        >>> import pathlib, tempfile
        >>> from ffd_notebook import FFD, Lattice
        >>> path = pathlib.Path(tempfile.mkdtemp()) / "TransformParameters.0.txt"
        >>> save_elastix(path, FFD(Lattice((4, 5, 4), 2.0)))
        >>> load_elastix(path).to_ffd().lattice.shape
        (4, 5, 4)
        """
        a, b = np.eye(3), np.zeros(3)
        grid: list[NDArray[np.float64]] | None = None  # direction, spacing, origin, offsets
        for index, step in enumerate(self.steps):
            how = self.combine[index - 1] if index else "Compose"
            if isinstance(step, LinearStep):
                m, t = step.matrix, step.offset
                if how == "Compose":
                    a, b = m @ a, m @ b + t
                    if grid is not None:
                        grid[3] = grid[3] @ m.T
                else:
                    a, b = m + a - np.eye(3), b + t
                continue
            if grid is not None:
                raise ValueError(f"{step.path}: a second B-spline transform in the chain; an FFD holds one lattice")
            grid = [step.direction.copy(), step.spacing.copy(), step.origin.copy(), step.coefficients.copy()]
            if how == "Compose" and not (np.array_equal(a, np.eye(3)) and not b.any()):
                # B(A x + b): the grid pulled back through x -> A x + b
                if not np.all(np.isfinite(a)) or np.linalg.cond(a) > 1e12:
                    raise ValueError(f"{step.path}: the linear map before the B-spline is singular")
                inverse = np.linalg.inv(a)
                grid[2] = inverse @ (step.origin - b)
                if not np.array_equal(a, np.eye(3)):
                    placement = inverse @ step.placement
                    grid[1] = np.linalg.norm(placement, axis=0)
                    grid[0] = placement / grid[1]
        if grid is None:
            raise ValueError("the chain holds no B-spline transform: no lattice to make an FFD of")
        lattice = _lattice(*grid)
        lattice.metadata["elastix"] = dict(self.geometry)
        affine = np.eye(4)
        affine[:3, :3], affine[:3, 3] = a, b
        stripped = strip_padding(lattice)
        if stripped is not None:
            stripped.metadata = lattice.metadata
            return FFD(stripped, "bspline", border="zero", affine=affine)
        return FFD(lattice, "bspline", border="zero", affine=affine, only_inside="half-open")

    def __repr__(self) -> str:
        parts = [self.steps[0].kind]
        for step, how in zip(self.steps[1:], self.combine, strict=True):
            parts.append(f"{'then' if how == 'Compose' else 'plus'} {step.kind}")
        return f"ElastixTransform({', '.join(parts)})"


def _lattice(rotation: NDArray[np.float64], spacing: NDArray[np.float64], origin: NDArray[np.float64],
             offsets: NDArray[np.float64]) -> Lattice:  # fmt: skip
    """The lattice with control point ``ijk`` at ``origin + rotation @ (spacing * ijk)`` (sheared if need be)."""
    snapped = nearest_rotation(rotation)  # rounded direction cosines: the rotation they round
    if snapped is None:  # a sheared grid: unit columns exactly, their lengths in the spacing
        lengths = np.linalg.norm(rotation, axis=0)
        rotation, spacing = rotation / lengths, spacing * lengths
    return Lattice(offsets.shape[:3], spacing, origin, rotation if snapped is None else snapped, offsets)


# ---------------------------------------------------------------------------------------- reading
def _center(params: ParameterMap) -> NDArray[np.float64]:
    return params.numbers("CenterOfRotationPoint", 3, why="elastix needs the centre of a rotation")


def _parameters(params: ParameterMap, count: int, kind: str) -> NDArray[np.float64]:
    if "ITKTransformParameters" in params:
        raise params.error("ITKTransformParameters", "ITKTransformParameters (an ITK transform inside an elastix "
                           "file) is not supported; expected TransformParameters")  # fmt: skip
    values = params.numbers("TransformParameters")
    if len(values) != count:
        raise params.error("TransformParameters", f"a 3D {kind} has {count} parameters, got {len(values)}")
    if "NumberOfParameters" in params:
        (declared,) = params.integers("NumberOfParameters", 1, low=0, high=2**40)
        if declared != count:
            raise params.error("NumberOfParameters", f"NumberOfParameters is {declared}, but there are {count} "
                               "TransformParameters")  # fmt: skip
    return values


def _euler(angles: NDArray[np.float64], zyx: bool) -> NDArray[np.float64]:
    cx, cy, cz = np.cos(angles)
    sx, sy, sz = np.sin(angles)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    rz = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
    return rz @ ry @ rx if zyx else rz @ rx @ ry


def _versor(params: ParameterMap, axis: NDArray[np.float64]) -> NDArray[np.float64]:
    """ITK's rotation matrix of a versor given by its vector part (``itkAdvancedSimilarity3DTransform``)."""
    norm = float(np.sqrt(axis @ axis))
    if norm >= 1.0 - 1e-10:
        axis = axis / (norm + 1e-10 * norm)
    x, y, z = axis
    w = np.sqrt(max(0.0, 1.0 - float(axis @ axis)))
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])  # fmt: skip


def _linear(params: ParameterMap, kind: str) -> LinearStep:
    if kind == "TranslationTransform":
        return LinearStep(kind, np.eye(3), _parameters(params, 3, kind), params.path)
    count = {"AffineTransform": 12, "EulerTransform": 6, "SimilarityTransform": 7}[kind]
    p = _parameters(params, count, kind)
    center = _center(params)
    if kind == "AffineTransform":
        matrix, translation = p[:9].reshape(3, 3), p[9:]
    elif kind == "EulerTransform":
        matrix, translation = _euler(p[:3], params.flag("ComputeZYX", False)), p[3:6]
    else:
        matrix, translation = p[6] * _versor(params, p[:3]), p[3:6]
    return LinearStep(kind, matrix, translation + center - matrix @ center, params.path)


def _bspline(params: ParameterMap, kind: str) -> BSplineStep:
    order = params.word("BSplineTransformSplineOrder", "3")
    if order != "3":
        raise params.error("BSplineTransformSplineOrder", f"B-spline order {order}: only cubic B-splines (order 3) "
                           "can be held exactly by an FFD")  # fmt: skip
    if params.flag("UseCyclicTransform", False):
        raise params.error("UseCyclicTransform", "a cyclic B-spline transform (UseCyclicTransform \"true\") has no "
                           "FFD equivalent")  # fmt: skip
    shape = params.integers("GridSize", 3, low=4, high=_MAX_AXIS)
    index = params.integers("GridIndex", 3, low=-(2**31), high=2**31) if "GridIndex" in params else [0, 0, 0]
    if kind == "RecursiveBSplineTransform" and any(index):
        raise params.error("GridIndex", "a RecursiveBSplineTransform with a GridIndex other than 0 0 0 (elastix "
                           "never writes one) is not supported")  # fmt: skip
    spacing = params.numbers("GridSpacing", 3)
    if np.any(spacing <= 0):
        raise params.error("GridSpacing", f"expected a positive grid spacing, got {spacing.tolist()}")
    origin = params.numbers("GridOrigin", 3)
    direction = params.numbers("GridDirection", 9).reshape(3, 3).T if "GridDirection" in params else np.eye(3)
    placement = direction * spacing
    if not np.all(np.isfinite(placement)) or np.linalg.cond(placement) > 1e12 or np.any(spacing == np.inf):
        raise params.error("GridDirection", "the grid direction is singular (its columns are not independent)")
    n = int(np.prod(shape))
    values = _parameters(params, 3 * n, f"{shape[0]}x{shape[1]}x{shape[2]} {kind}")
    coefficients = values.reshape(3, shape[2], shape[1], shape[0]).transpose(3, 2, 1, 0)
    first = origin + placement @ np.asarray(index, dtype=np.float64)
    if not np.all(np.isfinite(first)):
        raise params.error("GridOrigin", "the grid's first control point is not finite")
    return BSplineStep(kind, direction, spacing, first, np.ascontiguousarray(coefficients), params.path)


def _step(params: ParameterMap) -> ElastixStep:
    kind = params.word("Transform", why="it names the transform")
    for name in ("FixedImageDimension", "MovingImageDimension"):
        if name in params and params.word(name) != "3":
            raise params.error(name, f"{name} {params.word(name)}: only 3D transforms are supported")
    if kind in _LINEAR:
        return _linear(params, kind)
    if kind in _BSPLINE:
        return _bspline(params, kind)
    raise params.error("Transform", f"unsupported transform {kind!r}; expected one of "
                       f"{', '.join(_BSPLINE + _LINEAR)}")  # fmt: skip


def _candidates(current: Path, name: str) -> Iterable[Path]:
    """Where an ``InitialTransformParameterFileName`` may be: beside the file, as written, its last part beside it."""
    written = Path(name)
    if not written.is_absolute():
        yield current.parent / written
    yield written
    last = name.replace("\\", "/").rstrip("/").rsplit("/", 1)[-1]
    if last:
        yield current.parent / last


def _is_file(path: Path) -> bool:
    try:
        return path.is_file()
    except (OSError, ValueError):  # a name too long, or with a NUL in it: not there
        return False


def _same_file(a: Path, b: Path) -> bool:
    """Whether two existing files are the same file or hold the same bytes."""
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return read_bytes(a) == read_bytes(b)
    except (OSError, ValueError):
        return False


def _initial(params: ParameterMap, current: Path, within: str | os.PathLike[str] | None) -> Path | None:
    """The file before ``current`` in its chain, or None; looked for beside ``current`` first (see the module
    docstring). With ``within``, a candidate outside that folder is passed over without asking the file system
    about it, and "not found" is said the same way whether a file outside exists or not."""
    key = next((k for k in ("InitialTransformParameterFileName", "InitialTransformParametersFileName") if k in params),
               None)  # fmt: skip
    if key is None:
        return None
    name = params.values(key)[0]  # elastix reads the first value (a quoted name keeps its blanks)
    if name == "NoInitialTransform":
        return None
    candidates = list(_candidates(current, name))
    if within is not None:
        candidates = [c for c in candidates if is_inside(os.path.abspath(c), within)]
    found = [c for c in candidates if _is_file(c)]
    if not found:
        if within is not None:
            raise params.error(key, "the initial transform is not in the folder this file may read from "
                               f"({name!r}; an uploaded file cannot name others)")  # fmt: skip
        raise params.error(key, f"the initial transform {name!r} is not found (looked in {current.parent}, as "
                           f"written, and for {Path(name.replace(chr(92), '/')).name!r} beside it)")  # fmt: skip
    beside, written = current.parent / name, Path(name)
    if (not written.is_absolute() and found[0] == beside and written in found
            and not _same_file(beside, written)):  # fmt: skip
        raise params.error(key, "the initial transform is both beside this file and in the working folder, and "
                           f"the two differ: refused ({name!r} in {os.getcwd()}; move one away)")  # fmt: skip
    return Path(named_file(current, os.path.abspath(found[0]), within=within, what="initial transform",
                           line=params.line(key)))  # fmt: skip


def load_elastix(path: str | os.PathLike[str], *, within: str | os.PathLike[str] | None = None) -> ElastixTransform:
    """Read an elastix transform parameter file and the chain of files before it.

    Parameters
    ----------
    path : str or os.PathLike
        An elastix transform parameter file (``TransformParameters.N.txt``).
    within : str or os.PathLike, optional
        The folder every file of the chain must be in (the app passes its folder, or an upload's
        own folder, so an uploaded chain cannot name others); ``None``: anywhere.

    Returns
    -------
    ElastixTransform
        Moves points as transformix does with this file (its ``OutputPoint``); lower it onto an
        FFD with :meth:`ElastixTransform.to_ffd`.

    Raises
    ------
    FileFormatError
        A malformed file, an unsupported transform, a missing initial file, a chain that loops or
        is longer than :data:`MAX_CHAIN`; names the file and line.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "TransformParameters.0.txt").write_text(
    ...     '(Transform "TranslationTransform")\\n(TransformParameters 1 2 3)\\n'
    ...     '(InitialTransformParameterFileName "NoInitialTransform")\\n')
    >>> _ = (folder / "TransformParameters.1.txt").write_text(
    ...     '(Transform "EulerTransform")\\n(TransformParameters 0 0 1.5707963267948966 0 0 0)\\n'
    ...     '(CenterOfRotationPoint 0 0 0)\\n'
    ...     '(InitialTransformParameterFileName "/old/run/TransformParameters.0.txt")\\n')
    >>> chain = load_elastix(folder / "TransformParameters.1.txt")
    >>> chain, chain.deform([[0.0, 0.0, 0.0]]).round(12).tolist()
    (ElastixTransform(TranslationTransform, then EulerTransform), [[-2.0, 1.0, 3.0]])
    """
    current = Path(path)
    files: list[ParameterMap] = []
    seen: dict[str, Path] = {}
    while True:
        params = read_parameter_file(current)
        files.append(params)
        seen[os.path.realpath(current)] = current
        following = _initial(params, current, within)
        if following is None:
            break
        key = next(k for k in ("InitialTransformParameterFileName", "InitialTransformParametersFileName")
                   if k in params)  # fmt: skip
        if os.path.realpath(following) in seen:
            raise params.error(key, f"the chain of initial transforms loops back to {following}")
        if len(files) >= MAX_CHAIN:
            raise params.error(key, f"the chain of initial transforms is longer than {MAX_CHAIN} files")
        current = following
    files.reverse()
    steps = [_step(params) for params in files]
    combine = []
    for params in files[1:]:
        how = params.word("HowToCombineTransforms", "Compose")
        if how not in ("Compose", "Add"):
            raise params.error("HowToCombineTransforms", f"expected HowToCombineTransforms \"Compose\" or \"Add\", "
                               f"got {how!r}")  # fmt: skip
        combine.append(how)
    last = files[-1]
    geometry = {k: last.numbers(k).tolist() for k in GEOMETRY_KEYS if k in last}
    return ElastixTransform(steps, combine, geometry)


# ---------------------------------------------------------------------------------------- writing
def _common(geometry: dict[str, Any], lattice: Lattice) -> list[tuple[str, list[Any]]]:
    """The keys transformix needs besides the transform: dimensions, pixel types, the fixed image grid."""
    if all(k in geometry for k in GEOMETRY_KEYS):
        grid = [(k, [float(v) for v in geometry[k]]) for k in GEOMETRY_KEYS]
    else:  # the lattice's box, four voxels per cell
        grid = [("Size", [4 * (n - 1) + 1 for n in lattice.shape]), ("Index", [0, 0, 0]),
                ("Spacing", list(lattice.spacing / 4)), ("Origin", list(lattice.origin)),
                ("Direction", list(lattice.rotation.T.ravel()))]  # fmt: skip
    return [
        ("FixedImageDimension", [3]),
        ("MovingImageDimension", [3]),
        ("FixedInternalImagePixelType", ["float"]),
        ("MovingInternalImagePixelType", ["float"]),
        *grid,
        ("UseDirectionCosines", [True]),
        ("ResampleInterpolator", ["FinalBSplineInterpolator"]),
        ("FinalBSplineInterpolationOrder", [3]),
        ("Resampler", ["DefaultResampler"]),
        ("DefaultPixelValue", [0]),
        ("ResultImageFormat", ["nii"]),
        ("ResultImagePixelType", ["float"]),
        ("CompressResultImage", [False]),
    ]


def affine_file_name(path: str | os.PathLike[str]) -> Path:
    """The file :func:`save_elastix` writes an FFD's affine part to: ``name.affine.txt`` beside ``path``.

    Examples
    --------
    >>> affine_file_name("run/TransformParameters.1.txt").as_posix()
    'run/TransformParameters.1.affine.txt'
    """
    p = Path(path)
    return p.with_name(f"{p.stem}.affine{p.suffix or '.txt'}")


def save_elastix(path: str | os.PathLike[str], ffd: FFD) -> None:
    """Write an FFD as elastix transform parameter files that transformix applies exactly.

    A B-spline FFD (the "zero" border) becomes a ``BSplineTransform`` file at ``path``; a lattice
    that also moves points outside elastix's valid region (``only_inside=False``, the default) is
    written with three more layers of zero coefficients all round, which :func:`load_elastix`
    drops again. An affine part is written to :func:`affine_file_name` as an ``AffineTransform``,
    which the B-spline file names as its initial transform (by its bare name: elastix finds it
    beside the file, wherever the folder goes) with ``HowToCombineTransforms "Add"``. Both files
    are replaced atomically, the affine one first.

    Parameters
    ----------
    path : str or os.PathLike
        The B-spline file to write.
    ffd : FFD
        A B-spline FFD with the "zero" border.

    Raises
    ------
    ValueError
        The Bernstein basis or the "clamp" border (elastix's B-spline treats the grid's outside
        as zero), or a lattice file name that cannot be written.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import numpy as np
    >>> from ffd_notebook import FFD, Lattice
    >>> lat = Lattice((4, 4, 4), 2.0)
    >>> lat.offsets[1, 2, 1] = (0.5, 0.0, 0.0)
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "TransformParameters.0.txt"
    >>> save_elastix(path, FFD(lat, affine=np.diag([1.0, 2.0, 1.0, 1.0])))
    >>> sorted(p.name for p in path.parent.iterdir())
    ['TransformParameters.0.affine.txt', 'TransformParameters.0.txt']
    >>> back = load_elastix(path).to_ffd()
    >>> back.lattice.offsets.tolist() == lat.offsets.tolist(), back.affine[1, 1]
    (True, np.float64(2.0))
    """
    if not isinstance(ffd, FFD):
        raise TypeError(f"expected an FFD, got {type(ffd).__name__}")
    if ffd.basis != "bspline":
        raise ValueError(f"{os.fspath(path)}: an elastix file cannot hold this FFD exactly: it has the "
                         f"{ffd.basis!r} basis; elastix's B-spline transform is a cubic B-spline")  # fmt: skip
    if ffd.border != "zero":
        raise ValueError(f"{os.fspath(path)}: an elastix file cannot hold this FFD exactly: border="
                         f"{ffd.border!r}; elastix's B-spline treats control points outside its grid as zero "
                         "(border='zero')")  # fmt: skip
    if ffd.weights is not None:
        raise ValueError(f"{os.fspath(path)}: an elastix file cannot hold this FFD exactly: it has per-point "
                         "weights, which belong to one mesh")  # fmt: skip
    ffd = ffd.baked()  # a strength and "outside" mode are the offsets and affine part they give
    lat = ffd.lattice
    offsets, origin = lat.offsets, lat.origin
    if not ffd.only_inside:
        offsets = np.pad(offsets, ((_PAD, _PAD),) * 3 + ((0, 0),))
        origin = origin - lat.rotation @ (_PAD * lat.spacing)
    geometry = lat.metadata.get("elastix") or {}
    common = _common(geometry if isinstance(geometry, dict) else {}, lat)
    a, b = ffd.affine[:3, :3], ffd.affine[:3, 3]
    initial: str = "NoInitialTransform"
    if not (np.array_equal(a, np.eye(3)) and not b.any()):
        affine_path = affine_file_name(path)
        write_parameter_file(affine_path, [
            ("Transform", ["AffineTransform"]),
            ("NumberOfParameters", [12]),
            ("TransformParameters", [*a.ravel(), *b]),
            ("InitialTransformParameterFileName", ["NoInitialTransform"]),
            ("HowToCombineTransforms", ["Compose"]),
            ("CenterOfRotationPoint", [0.0, 0.0, 0.0]),
            *common,
        ])  # fmt: skip
        initial = affine_path.name
    shape = offsets.shape[:3]
    coefficients = np.ascontiguousarray(offsets.transpose(3, 2, 1, 0)).ravel()
    write_parameter_file(path, [
        ("Transform", ["BSplineTransform"]),
        ("NumberOfParameters", [coefficients.size]),
        ("TransformParameters", coefficients.tolist()),
        ("InitialTransformParameterFileName", [initial]),
        ("HowToCombineTransforms", ["Add"]),
        ("GridSize", list(shape)),
        ("GridIndex", [0, 0, 0]),
        ("GridSpacing", list(lat.spacing)),
        ("GridOrigin", list(origin)),
        ("GridDirection", list(lat.rotation.T.ravel())),
        ("BSplineTransformSplineOrder", [3]),
        ("UseCyclicTransform", [False]),
        *common,
    ])  # fmt: skip
