"""The face mesh's triangles: which of the landmark model's 468 points form each triangle.

MediaPipe publishes the canonical face mesh topology only as edges, ``FACEMESH_TESSELATION`` in
``mediapipe/python/solutions/face_mesh_connections.py`` (a ``frozenset``, so importing it loses the
order). The source lists the edges triangle by triangle, ``(a, b), (b, c), (c, a)``, so reading the
literal in file order gives the triangles. They were read once from the ``mediapipe`` 0.10.21 wheel
on PyPI into ``data/face_triangles.npy`` (852 triangles, uint16), the file this package ships::

    pip download --no-deps mediapipe==0.10.21 && unzip -o mediapipe-0.10.21-*.whl 'mediapipe/python/*'
    python -m ffd_notebook.face.topology mediapipe/python/solutions/face_mesh_connections.py

The listed triangles are consistently oriented (every inner edge is used once in each direction);
the mesh is a disc with three holes (the eyes and the mouth): 468 vertices, 1,322 edges, Euler
characteristic -2. :func:`triangles_from_edges` checks all of that when it reads the file.
"""

from __future__ import annotations

import ast
import os
import sys
from collections import Counter
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..errors import FileFormatError

__all__ = [
    "HOLE_CORNERS",
    "N_LANDMARKS",
    "TRIANGLES_FILE",
    "boundary_loops",
    "closed_face_triangles",
    "face_triangles",
    "fill_hole",
    "read_tessellation",
    "triangles_from_edges",
]

N_LANDMARKS = 468
# the corners of the mesh's three holes: the right eye, the left eye, the mouth (between the lips)
HOLE_CORNERS = ((33, 133), (263, 362), (78, 308))
TRIANGLES_FILE = Path(__file__).parent / "data" / "face_triangles.npy"


def triangles_from_edges(edges: list[tuple[int, int]]) -> np.ndarray:
    """Triangles from edges listed triangle by triangle: ``(a, b), (b, c), (c, a), ...``.

    Parameters
    ----------
    edges : list of (int, int)
        Directed edges in the order the triangles were written.

    Returns
    -------
    numpy.ndarray
        ``(len(edges) // 3, 3)`` int64 vertex indices, in the listed orientation.

    Raises
    ------
    ValueError
        If the edges do not come in closed triples, a triangle repeats, or two triangles use an edge
        in the same direction (an inconsistent orientation or a non-manifold edge).

    Examples
    --------
    >>> triangles_from_edges([(0, 1), (1, 2), (2, 0), (2, 1), (1, 3), (3, 2)])
    array([[0, 1, 2],
           [2, 1, 3]])
    >>> triangles_from_edges([(0, 1), (1, 2), (2, 0), (1, 2), (2, 3), (3, 1)])
    Traceback (most recent call last):
    ...
    ValueError: edge (1, 2) is used twice in the same direction: the triangles are not consistently oriented
    """
    if len(edges) % 3:
        raise ValueError(f"{len(edges)} edges: not a whole number of triangles")
    triangles = []
    for k in range(0, len(edges), 3):
        (a, b), (b2, c), (c2, a2) = edges[k : k + 3]
        if (b, c, a) != (b2, c2, a2) or len({a, b, c}) < 3:
            raise ValueError(f"edges {k}-{k + 2} {edges[k : k + 3]} do not close a triangle")
        triangles.append((a, b, c))
    used = Counter((int(t[i]), int(t[(i + 1) % 3])) for t in triangles for i in range(3))
    twice = [edge for edge, n in used.items() if n > 1]
    if twice:
        raise ValueError(
            f"edge {twice[0]} is used twice in the same direction: the triangles are not consistently oriented"
        )
    if len({frozenset(t) for t in triangles}) < len(triangles):
        raise ValueError("a triangle is listed twice")
    return np.array(triangles, dtype=np.int64).reshape(-1, 3)


def read_tessellation(path: str | os.PathLike[str]) -> np.ndarray:
    """The triangles of ``FACEMESH_TESSELATION`` in MediaPipe's ``face_mesh_connections.py``.

    The file is parsed (``ast``), not imported. Raises :class:`~ffd_notebook.errors.FileFormatError`
    if it has no such literal or its edges are not triangles of a 468-point mesh.
    """
    text = Path(path).read_text(encoding="utf-8")
    for node in ast.parse(text, filename=os.fspath(path)).body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", "") == "FACEMESH_TESSELATION" for t in node.targets):
            call = node.value
            if not (isinstance(call, ast.Call) and call.args):
                raise FileFormatError(path, node.lineno, "FACEMESH_TESSELATION is not frozenset([...])")
            try:
                triangles = triangles_from_edges(ast.literal_eval(call.args[0]))
            except ValueError as exc:
                raise FileFormatError(path, node.lineno, f"FACEMESH_TESSELATION: {exc}") from None
            if sorted(np.unique(triangles)) != list(range(N_LANDMARKS)):
                raise FileFormatError(path, node.lineno, f"the triangles do not use the points 0..{N_LANDMARKS - 1}")
            return triangles
    raise FileFormatError(path, None, "no FACEMESH_TESSELATION assignment")


@lru_cache(maxsize=1)
def face_triangles() -> np.ndarray:
    """The bundled face mesh's triangles: ``(852, 3)`` indices into the landmark model's 468 points.

    Examples
    --------
    >>> tri = face_triangles()
    >>> tri.shape, int(tri.max()) + 1
    ((852, 3), 468)
    """
    triangles = np.load(TRIANGLES_FILE, allow_pickle=False).astype(np.int64)
    triangles.setflags(write=False)
    return triangles


def boundary_loops(triangles: np.ndarray) -> list[list[int]]:
    """The closed chains of boundary edges of a consistently oriented triangle mesh, in the triangles' direction.

    Examples
    --------
    >>> boundary_loops(np.array([[0, 1, 2], [0, 2, 3]]))
    [[0, 1, 2, 3]]
    """
    directed = {(int(t[i]), int(t[(i + 1) % 3])) for t in triangles for i in range(3)}
    after = {a: b for a, b in directed if (b, a) not in directed}
    loops, seen = [], set()
    for first in sorted(after):
        if first in seen:
            continue
        loop = [first]
        seen.add(first)
        while (nxt := after[loop[-1]]) != first:
            loop.append(nxt)
            seen.add(nxt)
        loops.append(loop)
    return loops


def fill_hole(loop: list[int], corners: tuple[int, int]) -> np.ndarray:
    """Triangles closing a hole: a zigzag strip between its two sides from one corner to the other.

    ``loop`` runs the way the mesh's boundary edges do, so the new triangles use those edges
    backwards and the closed mesh stays consistently oriented. An eye or the lips (two rows of
    points from corner to corner) get a strip of triangles across, not a fan of slivers.

    Examples
    --------
    >>> fill_hole([0, 1, 2, 3, 4, 5], (0, 3))          # a hexagon, corners 0 and 3
    array([[1, 0, 5],
           [2, 1, 5],
           [2, 5, 4],
           [3, 2, 4]])
    """
    start = loop.index(corners[0])
    loop = loop[start:] + loop[:start]
    end = loop.index(corners[1])
    upper = loop[: end + 1]  # corner 0 -> corner 1 along the boundary
    lower = [loop[0], *loop[end:][::-1]]  # corner 0 -> corner 1 the other way
    last_u, last_l = len(upper) - 2, len(lower) - 2
    triangles = [(upper[1], upper[0], lower[1])]
    i = j = 1
    while (i, j) != (last_u, last_l):
        # advance along the side that is behind (in fraction of its length), so the strip stays even
        if j == last_l or (i < last_u and (i + 1) / len(upper) <= (j + 1) / len(lower)):
            triangles.append((upper[i + 1], upper[i], lower[j]))
            i += 1
        else:
            triangles.append((upper[i], lower[j], lower[j + 1]))
            j += 1
    triangles.append((upper[-1], upper[-2], lower[-2]))
    return np.array(triangles, dtype=np.int64)


@lru_cache(maxsize=1)
def closed_face_triangles() -> np.ndarray:
    """:func:`face_triangles` with the eyes and the mouth closed (:data:`HOLE_CORNERS`): a disc, 898 triangles.

    The holes are where the eyeballs and the teeth show in a photo; closed, they take the photo's
    colours like the rest of the face.

    Examples
    --------
    >>> tri = closed_face_triangles()
    >>> len(tri), len(boundary_loops(tri))              # only the face's outline is left open
    (898, 1)
    """
    base = face_triangles()
    loops = boundary_loops(base)
    fills = []
    for corners in HOLE_CORNERS:
        (loop,) = [lp for lp in loops if set(corners) <= set(lp)]
        fills.append(fill_hole(loop, corners))
    triangles = np.concatenate([base, *fills])
    triangles_from_edges([(int(t[i]), int(t[(i + 1) % 3])) for t in triangles for i in range(3)])  # check
    triangles.setflags(write=False)
    return triangles


def main(argv: list[str] | None = None) -> int:
    """``python -m ffd_notebook.face.topology face_mesh_connections.py [OUT.npy]``: write the triangle file."""
    args = sys.argv[1:] if argv is None else argv
    if len(args) not in (1, 2):
        print(main.__doc__, file=sys.stderr)
        return 2
    triangles = read_tessellation(args[0])
    out = Path(args[1]) if len(args) == 2 else TRIANGLES_FILE
    np.save(out, triangles.astype(np.uint16), allow_pickle=False)
    print(f"{out}: {len(triangles)} triangles")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
