"""A coloured 3D face from one photo, offline: MediaPipe's face detector and landmark models run by LiteRT.

:func:`face_from_photo` is the whole path, photo -> :class:`pyvista.PolyData`; the steps are public
too: :func:`detect_faces` (boxes and six key points), :func:`face_landmarks` (468 3D points on a
rotation-aligned crop), :func:`face_triangles` (MediaPipe's canonical topology). The models are
bundled (``ffd_notebook/face/data``, Apache-2.0, from the ``mediapipe`` 0.10.21 wheel); the runtime
is the ``ai-edge-litert`` package. Only :func:`face_from_photo` imports PyVista, when called.

Examples
--------
>>> from skimage import data
>>> from ffd_notebook.face import detect_faces, face_landmarks
>>> face = detect_faces(data.astronaut())[0]
>>> marks = face_landmarks(data.astronaut())
>>> bool(face.box[0] < marks.points[1, 0] < face.box[2])      # the nose tip is inside the detector's box
True
"""

from __future__ import annotations

from ..errors import NoFaceError
from .detection import FaceDetection, detect_faces
from .landmarks import FaceLandmarks, face_landmarks
from .mesh import face_from_photo
from .models import LiteRTMissingError
from .photo import PHOTO_SUFFIXES, Photo, decode_photo, is_photo, read_photo
from .topology import face_triangles

__all__ = [
    "PHOTO_SUFFIXES",
    "FaceDetection",
    "FaceLandmarks",
    "LiteRTMissingError",
    "NoFaceError",
    "Photo",
    "decode_photo",
    "detect_faces",
    "face_from_photo",
    "face_landmarks",
    "face_triangles",
    "is_photo",
    "read_photo",
]
