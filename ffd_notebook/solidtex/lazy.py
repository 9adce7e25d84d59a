"""Lazy solid textures: synthesised only where they are sampled, the same colours whatever is asked first.

:class:`LazySolidTexture` is per-voxel pyramid synthesis (:mod:`~ffd_notebook.solidtex.pyramid`, after
Dong, Lefebvre, Tong and Drettakis, "Lazy solid texture synthesis", EGSR 2008): every voxel's
coordinate into the exemplar is a function of its position that depends only on a bounded
neighbourhood at the coarser level. The levels that are corrected are kept in tiles of
``TILE^3`` voxels (an atlas per level, a grid of slots saying where each tile is), made when a
sampled point first needs them, with the coarser tiles they depend on; the finest level is each
voxel's parent coordinate plus its own offset, computed when sampled and not kept. So memory and
time follow the sampled surface, not the box around the organ; and because a voxel's coordinate is
a pure function of its position, :meth:`LazySolidTexture.volume` can cut the box into chunks and
compute them anywhere (on a Dask cluster), with the very same result.

:class:`~ffd_notebook.solidtex.LazyBlockTexture` is the seed's lazy block synthesis, kept by name.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._util.blas import one_blas_thread
from .._util.deprecation import renamed_keyword
from .pyramid import MARGIN, PyramidExemplar, box_positions, boxes, dependency, region
from .seeding import RNGLike, integer_seed
from .slices import exemplar_volume

__all__ = ["LazySolidTexture"]

FINE_TILE = 4  # voxels per tile edge at the two finest levels: a surface's shell there is a voxel or two thick
TILE = 16  # at the level before them (powers of two); the coarser levels are synthesised whole
_PAD = 8  # voxels around a level synthesised whole: its finer level's dependencies reach beyond the box
_BATCH_VOXELS = 2**20  # voxels (with their margins) synthesised in one batch of tiles
_CORNERS = np.array(list(itertools.product((0, 1), repeat=3)))  # of a unit cube


class LazyTexture:
    """What the lazy textures share: placement in the rest frame and trilinear sampling of their :meth:`voxels`.

    Subclasses set ``shape`` (voxels ``(Z, Y, X)``), ``spacing``, ``origin`` and define ``voxels``.
    """

    shape: tuple[int, ...]
    spacing: float
    origin: NDArray[np.float64]

    def __init__(self, exemplar: ArrayLike, shape: int | tuple[int, int, int], **options: Any) -> None:
        raise NotImplementedError  # pragma: no cover - the subclasses' constructors place the texture

    @classmethod
    def fit(cls, exemplar: ArrayLike, bounds: ArrayLike, *, resolution: int = 256, margin: float = 0.02, **kwargs):
        """A lazy texture over a box, ``resolution`` voxels along its longest side.

        ``kwargs`` go to the constructor (``rng``, ...); ``seed=`` is a deprecated alias of ``rng``
        (a :class:`DeprecationWarning`).

        Parameters
        ----------
        exemplar : array_like
            ``(Z, Y, X, 3)`` exemplar.
        bounds : array_like
            ``(xmin, xmax, ymin, ymax, zmin, zmax)``, e.g. ``mesh.bounds`` of the rest mesh.
        resolution : int
            Voxels along the box's longest side (with its margin).
        margin : float
            Extra room around the box, as a fraction of its size.
        **kwargs
            The constructor's options.

        Returns
        -------
        LazyTexture
            The texture (of the class it is called on), centred on the box, with cubic voxels.

        Examples
        --------
        >>> from ffd_notebook.solidtex import LazySolidTexture
        >>> ex = np.random.default_rng(0).integers(0, 256, (16, 16, 16, 3), dtype=np.uint8)
        >>> tex = LazySolidTexture.fit(ex, (0, 10, 0, 5, 0, 2), resolution=512)
        >>> tex.shape, round(tex.spacing, 4)
        ((103, 256, 512), 0.0199)
        """
        if "seed" in kwargs:
            kwargs["rng"] = renamed_keyword(kwargs, "seed", "rng", kwargs.get("rng", 0), f"{cls.__name__}.fit")
        b = np.asarray(bounds, dtype=np.float64).reshape(3, 2)
        extent = (b[:, 1] - b[:, 0]) * (1.0 + margin)
        spacing = float(extent.max() / resolution)
        shape_xyz = np.maximum(np.ceil(extent / spacing).astype(int), 1)
        origin = b.mean(axis=1) - spacing * (shape_xyz - 1) / 2.0
        zyx = (int(shape_xyz[2]), int(shape_xyz[1]), int(shape_xyz[0]))
        return cls(exemplar, zyx, spacing=spacing, origin=origin, **kwargs)

    def voxel_coordinates(self, points: ArrayLike) -> NDArray[np.float64]:
        """``(N, 3)`` fractional voxel indices ``(k, j, i)`` of world points, clamped to the texture.

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points in physical coordinates.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` float64 indices ``(k, j, i)``.

        Examples
        --------
        >>> from ffd_notebook.solidtex import LazySolidTexture
        >>> exemplar = np.random.default_rng(0).integers(0, 255, (16, 16, 16, 3), dtype=np.uint8)
        >>> lazy = LazySolidTexture.fit(exemplar, [0, 10, 0, 10, 0, 10], resolution=24, rng=0)
        >>> bool(np.all(lazy.voxel_coordinates([[-100.0, 5.0, 5.0]]) >= 0))   # clamped
        True
        """
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        c = ((p - self.origin) / self.spacing)[:, ::-1]
        return np.clip(c, 0.0, np.array(self.shape, dtype=np.float64) - 1.0)

    def voxels(self, indices: ArrayLike) -> NDArray[np.uint8]:  # pragma: no cover - every subclass defines it
        """Colours of integer voxels, synthesising what they need (each subclass defines it).

        Parameters
        ----------
        indices : array_like
            ``(N, 3)`` integer voxel indices ``(k, j, i)``, inside ``shape``.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` uint8 colours.

        Examples
        --------
        >>> from ffd_notebook.solidtex import LazySolidTexture
        >>> ex = np.random.default_rng(0).integers(0, 256, (16, 16, 16, 3), dtype=np.uint8)
        >>> LazySolidTexture(ex, 32, rng=0).voxels([[0, 0, 0], [31, 31, 31]]).shape
        (2, 3)
        """
        raise NotImplementedError

    def sample(self, points: ArrayLike) -> NDArray[np.uint8]:
        """Trilinearly interpolated ``(N, 3)`` uint8 colours at rest-frame points (clamped at the borders).

        Parameters
        ----------
        points : array_like
            ``(N, 3)`` points in the organ's rest frame.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` uint8 colours.

        Examples
        --------
        >>> from ffd_notebook.solidtex import LazySolidTexture
        >>> exemplar = np.random.default_rng(0).integers(0, 255, (16, 16, 16, 3), dtype=np.uint8)
        >>> lazy = LazySolidTexture.fit(exemplar, [0, 10, 0, 10, 0, 10], resolution=24, rng=0)
        >>> lazy.sample([[5.0, 5.0, 5.0]]).dtype, lazy.sample([[5.0, 5.0, 5.0]]).shape
        (dtype('uint8'), (1, 3))
        """
        c = self.voxel_coordinates(points)
        top = np.maximum(np.array(self.shape) - 2, 0)
        i0 = np.minimum(np.floor(c).astype(np.int64), top).clip(0)
        f = (c - i0).astype(np.float32)
        corners = list(itertools.product((0, 1), repeat=3))
        index = np.concatenate([np.minimum(i0 + d, np.array(self.shape) - 1) for d in corners])
        colours = self.voxels(index).astype(np.float32).reshape(len(corners), len(c), 3)
        acc = np.zeros((len(c), 3), dtype=np.float32)
        for colour, d in zip(colours, corners, strict=True):
            acc += np.prod(np.where(np.array(d, bool), f, 1.0 - f), axis=1)[:, None] * colour
        return np.clip(np.rint(acc), 0, 255).astype(np.uint8)


class _WholeLevel:
    """A coarse pyramid level synthesised whole, over the texture's box at that level and :data:`_PAD` around it
    (at most 1/512 of the finest level's voxels: 0.3 M for a 512^3 texture)."""

    def __init__(self, size: tuple[int, ...]) -> None:
        self.size = size
        self.coordinates: NDArray[np.int32] | None = None

    def make(self, prepared: PyramidExemplar, seed: int, level: int) -> None:
        if self.coordinates is None:
            self.coordinates = region(prepared, seed, level, (-_PAD,) * 3, tuple(n + _PAD for n in self.size))

    def lookup(self, z: NDArray[np.int64], y: NDArray[np.int64], x: NDArray[np.int64]) -> NDArray[np.int32]:
        assert self.coordinates is not None  # made first
        return self.coordinates[z + _PAD, y + _PAD, x + _PAD]

    @property
    def nbytes(self) -> int:
        return 0 if self.coordinates is None else int(self.coordinates.nbytes)


class _LevelCache:
    """One pyramid level's synthesised tiles: an atlas of ``tile^3`` coordinate blocks and the slot of each tile."""

    def __init__(self, size: tuple[int, ...], tile: int) -> None:
        self.tile = tile
        # tile t covers [t * tile - _PAD, (t + 1) * tile - _PAD): the dependencies of the texture's border reach a
        # few voxels below 0 and beyond its size, and a tile of its own for those few would be wasted work
        self.slots = np.full(tuple(-(-(n + 2 * _PAD) // tile) for n in size), -1, dtype=np.int32)
        self.atlas = np.zeros((0, tile, tile, tile), dtype=np.int32)
        self.count = 0

    @property
    def nbytes(self) -> int:
        return int(self.atlas[: self.count].nbytes + self.slots.nbytes)

    def tiles_of(self, positions: NDArray[np.int64]) -> NDArray[np.int64]:
        """The tile index of each position ``(N, 3)`` of the level."""
        return (positions + _PAD) // self.tile

    def missing(self, tiles: NDArray[np.int64]) -> NDArray[np.int64]:
        """The tiles (unique, ``(N, 3)`` tile indices) not synthesised yet."""
        if len(tiles) and (tiles.min() < 0 or np.any(tiles.max(axis=0) >= np.array(self.slots.shape))):
            raise RuntimeError(f"tiles beyond {self.slots.shape} lie outside the texture's levels")
        keys = np.unique(np.ravel_multi_index(tuple(tiles.T), self.slots.shape))  # 1D: far faster than axis=0
        keys = keys[self.slots.reshape(-1)[keys] < 0]
        return np.stack(np.unravel_index(keys, self.slots.shape), axis=-1)

    def origins(self, tiles: NDArray[np.int64]) -> NDArray[np.int64]:
        """The first position of each tile."""
        return tiles * self.tile - _PAD

    def store(self, tiles: NDArray[np.int64], coordinates: NDArray[np.int32]) -> None:
        end = self.count + len(tiles)
        if end > len(self.atlas):
            grown = np.zeros((max(end, 2 * len(self.atlas)), *self.atlas.shape[1:]), dtype=np.int32)
            grown[: self.count] = self.atlas[: self.count]
            self.atlas = grown
        self.atlas[self.count : end] = coordinates
        self.slots[tuple(tiles.T)] = np.arange(self.count, end)
        self.count = end

    def lookup(self, z: NDArray[np.int64], y: NDArray[np.int64], x: NDArray[np.int64]) -> NDArray[np.int32]:
        """Coordinates at (broadcastable) positions of the level, whose tiles are synthesised."""
        t = self.tile
        z, y, x = z + _PAD, y + _PAD, x + _PAD
        return self.atlas[self.slots[z // t, y // t, x // t], z % t, y % t, x % t]


def _chunk_colours(prepared: PyramidExemplar, seed: int, lo, hi) -> NDArray[np.uint8]:
    """Colours of the finest level over ``[lo, hi)``: one chunk of :meth:`LazySolidTexture.volume`."""
    coordinates = region(prepared, seed, prepared.n_levels - 1, lo, hi)
    return prepared.colour(coordinates)


class LazySolidTexture(LazyTexture):
    """A solid texture synthesised voxel by voxel where it is sampled: per-voxel pyramid synthesis.

    Each voxel's colour is the exemplar's at a coordinate synthesised coarse to fine
    (:mod:`~ffd_notebook.solidtex.pyramid`): whole cells, no blocks, no grid, and no region
    repeated. Only the tiles a sampled point needs are made (with the coarser tiles they depend
    on), and they are kept; the colours are the same whatever is sampled first.

    Parameters
    ----------
    exemplar : array_like
        ``(Z, Y, X, 3)`` exemplar (e.g. :func:`~ffd_notebook.solidtex.exemplar_from_image`), at least
        8 voxels a side; uint8, uint16 or floats in [0, 1] (the package's dtype policy). Best
        periodic: coordinates wrap around it.
    shape : int or (int, int, int)
        Voxels ``(Z, Y, X)`` the texture covers (it may be far too large to hold whole).
    spacing : float
        Voxel edge in world units.
    origin : array_like
        World ``(x, y, z)`` of voxel ``[0, 0, 0]``'s centre.
    rng : int or numpy.random.Generator
        Same int, same colours, whatever is sampled first: every random number is a hash of one
        integer root seed and a position (a Generator gives one 63-bit draw as the root seed,
        :func:`~ffd_notebook.solidtex.seeding.integer_seed`, kept as ``seed``).
    levels : int, optional
        Pyramid levels (default: the coarsest step the largest power of two at most a quarter of
        the exemplar's side, :func:`~ffd_notebook.solidtex.pyramid.default_levels`).
    prepared : PyramidExemplar, optional
        The exemplar already prepared (:class:`~ffd_notebook.solidtex.pyramid.PyramidExemplar`):
        several textures of one exemplar share it.

    Attributes
    ----------
    seed : int
        The integer root seed.
    prepared : PyramidExemplar
        The exemplar's levels.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> ex = np.kron(rng.integers(0, 256, (4, 4, 4, 3)), np.ones((4, 4, 4, 1), int)).astype(np.uint8)
    >>> tex = LazySolidTexture(ex, shape=1000)                  # a billion voxels, none made yet
    >>> colours = tex.sample([[10.0, 20.0, 30.0], [500.5, 2.0, 999.0]])
    >>> colours.shape, tex.voxels_synthesised < 10**6
    ((2, 3), True)
    >>> other = LazySolidTexture(ex, shape=1000, prepared=tex.prepared)
    >>> _ = other.sample([[500.5, 2.0, 999.0]])                 # the other point first
    >>> bool(np.array_equal(other.sample([[10.0, 20.0, 30.0], [500.5, 2.0, 999.0]]), colours))
    True
    """

    def __init__(
        self,
        exemplar: ArrayLike,
        shape: int | tuple[int, int, int],
        *,
        spacing: float = 1.0,
        origin: ArrayLike = (0.0, 0.0, 0.0),
        rng: RNGLike = 0,
        levels: int | None = None,
        prepared: PyramidExemplar | None = None,
    ) -> None:
        target = (int(shape),) * 3 if isinstance(shape, (int, np.integer)) else tuple(int(s) for s in shape)
        if len(target) != 3 or min(target) < 1:
            raise ValueError(f"shape must be three positive sizes, got {shape}")
        if prepared is None:
            ex = exemplar_volume(exemplar)
            if min(ex.shape[:3]) < 8:
                raise ValueError(f"the exemplar must be at least 8 voxels a side, got {ex.shape[:3]}")
            prepared = PyramidExemplar(ex, levels)
        self.prepared = prepared
        self.seed = integer_seed(rng)
        self.shape = target
        self.spacing, self.origin = float(spacing), np.asarray(origin, dtype=np.float64).reshape(3)
        self._finest = prepared.n_levels - 1
        # the two finest levels in small tiles, the one before in larger ones, the one before that whole
        self._levels: dict[int, _WholeLevel | _LevelCache] = {}
        size = tuple(2 * n for n in target)
        for level, tile in zip(range(self._finest, -1, -1), (FINE_TILE, FINE_TILE, TILE, None), strict=False):
            size = tuple(-(-n // 2) for n in size)  # the level's extent: the finer one's (tiles rounded up), halved
            self._levels[level] = _WholeLevel(size) if tile is None else _LevelCache(size, tile)
            if tile is not None:  # what its tiles cover
                size = tuple(-(-(n + 2 * _PAD) // tile) * tile - _PAD for n in size)

    # -- synthesis -------------------------------------------------------------------------------

    def _need(self, level: int, lo: NDArray[np.int64], size: int) -> tuple[NDArray[np.int64], NDArray[np.int32]]:
        """Level ``level``'s coordinates over cubes of edge ``size`` at ``lo`` (``(N, 3)``), synthesised if need be,
        as ``(lo, coordinates)``: what :func:`~ffd_notebook.solidtex.pyramid.boxes` takes as ``coarse``."""
        store = self._levels[level]
        if isinstance(store, _WholeLevel):
            store.make(self.prepared, self.seed, level)
        else:
            ends = lo if size == 1 else (lo[:, None, :] + _CORNERS * (size - 1)).reshape(-1, 3)
            self._ensure(level, store.tiles_of(ends))  # (a cube no larger than a tile: its corners' tiles)
        return lo, store.lookup(*box_positions(lo, (size, size, size)))

    def _ensure(self, level: int, tiles: NDArray[np.int64]) -> None:
        """Synthesise the tiles of ``level`` (and what they need of the coarser levels) not made yet."""
        cache = self._levels[level]
        assert isinstance(cache, _LevelCache)  # the tiled levels
        tile = cache.tile
        todo = cache.missing(tiles)
        at_once = max(1, _BATCH_VOXELS // (tile + 2 * MARGIN) ** 3)
        for start in range(0, len(todo), at_once):
            batch = todo[start : start + at_once]
            lo = cache.origins(batch)
            coarse = None
            if level > 0:
                clo, chi = dependency(self.prepared, level, lo, lo + tile)
                coarse = self._need(level - 1, clo, int((chi - clo).max()))  # a cube: tiles and margins are even
            cache.store(batch, boxes(self.prepared, self.seed, level, lo, (tile,) * 3, coarse))

    def _coordinates(self, voxels: NDArray[np.int64]) -> NDArray[np.int32]:
        """Exemplar coordinates (packed) of finest voxels ``(N, 3)``, synthesised on demand."""
        with one_blas_thread():
            return self._need(self._finest, voxels, 1)[1].reshape(-1)

    # -- sampling --------------------------------------------------------------------------------

    @property
    def tiles_synthesised(self) -> int:
        """Tiles of the three finest levels synthesised so far."""
        return sum(c.count for c in self._levels.values() if isinstance(c, _LevelCache))

    @property
    def voxels_synthesised(self) -> int:
        """Finest voxels synthesised so far (in whole tiles)."""
        finest = self._levels[self._finest]
        assert isinstance(finest, _LevelCache)
        return finest.count * finest.tile**3

    @property
    def nbytes(self) -> int:
        """Memory held by the synthesised levels and their slot grids (the prepared exemplar aside)."""
        return sum(c.nbytes for c in self._levels.values())

    def voxels(self, indices: ArrayLike) -> NDArray[np.uint8]:
        """Colours of integer voxels ``(N, 3)`` ``(k, j, i)``, synthesising what they need.

        Parameters
        ----------
        indices : array_like
            ``(N, 3)`` integer voxel indices ``(k, j, i)``, inside ``shape``.

        Returns
        -------
        numpy.ndarray
            ``(N, 3)`` uint8 colours.

        Examples
        --------
        >>> from ffd_notebook.solidtex import LazySolidTexture
        >>> exemplar = np.random.default_rng(0).integers(0, 255, (16, 16, 16, 3), dtype=np.uint8)
        >>> lazy = LazySolidTexture.fit(exemplar, [0, 10, 0, 10, 0, 10], resolution=24, rng=0)
        >>> bool((lazy.voxels([[0, 0, 0]]) == lazy.volume()[0, 0, 0]).all())
        True
        """
        v = np.asarray(indices, dtype=np.int64).reshape(-1, 3)
        if len(v) and (v.min(axis=0).min() < 0 or np.any(v.max(axis=0) >= np.array(self.shape))):
            raise IndexError(f"voxel indices must lie in the texture's shape {self.shape}")
        return self.prepared.colour(self._coordinates(v))

    def volume(
        self, *, chunk: int = 64, scheduler: str | None = None, client: Any = None, progress: bool = False
    ) -> NDArray[np.uint8]:
        """The whole ``shape`` volume, computed in chunks (on a Dask cluster if asked): the same at every setting.

        Each ``chunk^3`` box is synthesised on its own with the coarser levels it depends on
        (:func:`~ffd_notebook.solidtex.pyramid.region`); a voxel depends only on its bounded
        neighbourhood, so the chunks agree with each other, with the tiles :meth:`sample` makes and
        with any other chunk size. Nothing is kept in the texture's tiles.

        Parameters
        ----------
        chunk : int
            Edge of the chunks (finest voxels).
        scheduler : str, optional
            ``"threads"``, ``"processes"`` or ``"sync"`` (Dask's local schedulers), or a
            ``distributed`` scheduler address such as ``"tcp://10.0.0.5:8786"`` (as
            ``python -m ffd_notebook batch --scheduler``); by default the chunks run here, one after
            the other.
        client : distributed.Client, optional
            Run the chunks on this cluster (e.g. :func:`~ffd_notebook.batch.local_cluster`'s).
        progress : bool
            Show a progress bar (one tick per chunk) when the chunks run here.

        Returns
        -------
        numpy.ndarray
            ``(Z, Y, X, 3)`` uint8.

        Examples
        --------
        >>> from ffd_notebook.solidtex import LazySolidTexture
        >>> exemplar = np.random.default_rng(0).integers(0, 255, (16, 16, 16, 3), dtype=np.uint8)
        >>> lazy = LazySolidTexture(exemplar, (20, 30, 12), rng=0)
        >>> whole = lazy.volume()
        >>> whole.shape, bool(np.array_equal(whole, lazy.volume(chunk=8, scheduler="threads")))
        ((20, 30, 12, 3), True)
        """
        if chunk < 1:
            raise ValueError(f"chunk must be a positive number of voxels, got {chunk}")
        starts = list(itertools.product(*[range(0, n, chunk) for n in self.shape]))
        spans = [(lo, tuple(min(a + chunk, n) for a, n in zip(lo, self.shape, strict=True))) for lo in starts]
        out = np.empty((*self.shape, 3), dtype=np.uint8)
        if client is None and scheduler is None:
            from tqdm.auto import tqdm

            for lo, hi in tqdm(spans, desc="solid texture", unit="chunk", disable=not progress):
                out[tuple(slice(a, b) for a, b in zip(lo, hi, strict=True))] = _chunk_colours(
                    self.prepared, self.seed, lo, hi
                )
            return out
        for (lo, hi), colours in zip(spans, _on_dask(self.prepared, self.seed, spans, scheduler, client), strict=True):
            out[tuple(slice(a, b) for a, b in zip(lo, hi, strict=True))] = colours
        return out


def _on_dask(prepared: PyramidExemplar, seed: int, spans, scheduler: str | None, client: Any) -> list:
    """The chunks' colours computed by Dask: a local scheduler, a cluster's client, or a scheduler's address."""
    import dask

    if client is None and scheduler in ("threads", "processes", "sync"):
        shared = dask.delayed(prepared, pure=True)
        tasks = [dask.delayed(_chunk_colours, pure=True)(shared, seed, lo, hi) for lo, hi in spans]
        return list(dask.compute(*tasks, scheduler=scheduler))
    if client is None:
        from distributed import Client

        with Client(scheduler) as remote:  # an address: tcp://host:8786
            return _on_client(remote, prepared, seed, spans)
    return _on_client(client, prepared, seed, spans)


def _on_client(client: Any, prepared: PyramidExemplar, seed: int, spans) -> list:
    shared = client.scatter(prepared, broadcast=True)  # the exemplar's tables once per worker, not once per chunk
    futures = [client.submit(_chunk_colours, shared, seed, lo, hi, pure=False) for lo, hi in spans]
    return client.gather(futures)
