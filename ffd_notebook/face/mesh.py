"""A coloured 3D face mesh from one photo: landmarks -> triangles -> subdivision -> colours, in millimetres.

Builds on :mod:`.landmarks` (NumPy and LiteRT) and makes a :class:`pyvista.PolyData`; PyVista is
imported inside :func:`face_from_photo` only, like the other mesh-making functions of the model.
"""

from __future__ import annotations

import os
import time
from typing import TYPE_CHECKING

import numpy as np

from .crop import bilinear
from .landmarks import LEFT_EYE_OUTER, RIGHT_EYE_OUTER, find_face, landmarks_of_face
from .photo import Photo
from .topology import closed_face_triangles

if TYPE_CHECKING:
    import pyvista as pv

__all__ = ["FACE_WIDTH_MM", "LEFT_FACE_EDGE", "RIGHT_FACE_EDGE", "face_frame", "face_from_photo"]

FACE_WIDTH_MM = 140.0
# MediaPipe's landmarks at the face outline's widest points, at the cheekbones (the subject's right and left)
RIGHT_FACE_EDGE = 234
LEFT_FACE_EDGE = 454


def face_frame(points: np.ndarray, *, width_mm: float = FACE_WIDTH_MM) -> tuple[np.ndarray, np.ndarray, float]:
    """The placement that turns landmark pixels into the face's millimetres: ``mm = (px - origin) @ axes * scale``.

    * scale: the 3D distance between landmarks 234 and 454 (the face outline's widest points at the
      cheekbones, the bizygomatic breadth, ~140 mm for an adult) becomes ``width_mm``;
    * axes: x along the line from the right eye's outer corner to the left eye's (landmarks 33 and
      263: the head's roll is undone), y up, z towards the camera (the face looks along +z);
    * origin: the centre of the landmarks' bounding box in those axes.

    A rotation, not a reflection: a mirrored photo gives a mirrored face, not a flipped mesh.

    Returns
    -------
    origin : (3,) array, axes : (3, 3) array (columns: the mesh's x, y, z in pixel coordinates), scale : float
    """
    d = points[LEFT_EYE_OUTER, :2] - points[RIGHT_EYE_OUTER, :2]
    c, s = d / np.hypot(*d)
    # pixel frame: x right, y down, z away from the camera; the mesh: x along the eyes, y up, z towards the camera
    axes = np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]])
    scale = width_mm / float(np.linalg.norm(points[LEFT_FACE_EDGE] - points[RIGHT_FACE_EDGE]))
    local = points @ axes
    origin = ((local.min(axis=0) + local.max(axis=0)) / 2) @ axes.T  # back to pixels (axes is orthogonal)
    return origin, axes, scale


def face_from_photo(
    photo: str | os.PathLike[str] | np.ndarray | Photo,
    *,
    index: int = 0,
    subdivisions: int = 3,
    width_mm: float = FACE_WIDTH_MM,
    timings: dict[str, float] | None = None,
) -> pv.PolyData:
    """A coloured 3D face mesh from one photo, offline (MediaPipe's face detector and landmark model).

    The largest face of the photo (or the ``index``-th by size) is found, cropped and turned
    upright as the landmark model expects, and its 468 3D landmarks are joined by MediaPipe's
    canonical triangles (852), refined by butterfly subdivision (interpolating: the landmarks stay
    where the model put them) and coloured from the photo.

    Parameters
    ----------
    photo : path, array or Photo
        A PNG or JPEG file (anything Pillow reads; EXIF orientation applied), an ``(H, W, 3)``
        uint8 RGB array (``(H, W)`` grey and ``(H, W, 4)`` RGBA work too), or the
        :class:`~ffd_notebook.face.Photo` of an upload's bytes (:func:`~ffd_notebook.face.decode_photo`).
        A large photo is shrunk for the models, and coloured at full resolution.
    index : int
        Which face, counted from the largest (0).
    subdivisions : int
        Butterfly subdivision levels; each multiplies the triangles by 4. 3 (the default) gives
        28,881 vertices and 57,472 triangles; 2 gives 7,257 and 14,368; 0 the 468 landmarks.
    width_mm : float
        The face's width between the outline's widest points at the cheekbones (landmarks 234 and
        454), which sets the scale: 140 mm, an adult's.
    timings : dict, optional
        If given, filled with the seconds spent in ``"detection"`` (with reading the photo),
        ``"landmarks"``, ``"subdivision"``, ``"colours"`` and ``"total"``.

    Returns
    -------
    pyvista.PolyData
        Triangles in millimetres, +y up, the face looking along +z (the roll of a tilted head
        undone). Point ``i < 468`` is MediaPipe's landmark ``i`` (4 the tip of the nose, 33 and 263
        the right and left eyes' outer corners). Point data ``"RGB"`` (uint8, the active scalars, as
        :func:`~ffd_notebook.io.read_obj` gives them): the photo's colour at each vertex,
        bilinear at full resolution. Texture coordinates into the photo (VTK's: u to the right, v
        upwards, in [0, 1]), so ``mesh.plot(texture=pv.Texture(photo))`` shows the photo on it.
        Field data ``"photo_size"``: the photo's ``(width, height)`` in pixels.

    Raises
    ------
    NoFaceError
        If the photo has no face (the message names the file and says so).
    FileFormatError
        If the file is not an image.
    LiteRTMissingError
        If ``ai-edge-litert`` is not installed (an ``ImportError`` that says what to install).

    Examples
    --------
    >>> import ffd_notebook as fn
    >>> from skimage import data
    >>> mesh = fn.face_from_photo(data.astronaut())
    >>> mesh.n_points, mesh.point_data["RGB"].dtype.name
    (28881, 'uint8')
    >>> round(float(np.linalg.norm(mesh.points[454] - mesh.points[234])))      # millimetres
    140
    >>> int(np.argmax(mesh.points[:468, 2]))                 # landmark 4, the tip of the nose, is the nearest
    4
    >>> fn.face_from_photo(data.coins())
    Traceback (most recent call last):
    ...
    ffd_notebook.errors.NoFaceError: the photo (a 384x303 array): no face found in the photo
    """
    import pyvista as pv

    start = time.perf_counter()
    photo = Photo.of(photo)
    face = find_face(photo, index=index)
    detected = time.perf_counter()
    marks = landmarks_of_face(photo, face)
    found = time.perf_counter()
    mesh = pv.PolyData.from_regular_faces(marks.points, closed_face_triangles())
    if subdivisions:
        mesh = mesh.subdivide(subdivisions, "butterfly")
    pixels = np.asarray(mesh.points, dtype=np.float64)  # x right, y down, z: MediaPipe's depth, in pixels
    subdivided = time.perf_counter()
    colours = bilinear(photo.rgb, pixels[:, :2]).round().clip(0, 255).astype(np.uint8)
    coloured = time.perf_counter()

    origin, axes, scale = face_frame(marks.points, width_mm=width_mm)
    mesh.points = (pixels - origin) @ axes * scale
    mesh.point_data["RGB"] = colours
    mesh.point_data.active_scalars_name = "RGB"
    mesh.active_texture_coordinates = np.column_stack(
        [pixels[:, 0] / photo.width, 1.0 - pixels[:, 1] / photo.height]
    ).astype(np.float32)
    mesh.field_data["photo_size"] = np.array([photo.width, photo.height])
    if timings is not None:
        timings.update(
            {
                "detection": detected - start,
                "landmarks": found - detected,
                "subdivision": subdivided - found,
                "colours": coloured - subdivided,
                "total": time.perf_counter() - start,
            }
        )
    return mesh
