"""The 468 3D landmarks of a face: MediaPipe's face landmark model on a rotation-aligned crop.

As MediaPipe's ``face_landmark_front_cpu`` graph does for one image
(``face_detection_front_detection_to_roi.pbtxt``, ``face_landmark_cpu.pbtxt``, 0.10.21):

* the crop (DetectionsToRects + RectTransformation): centred on the detector's box, a square of
  1.5 times its longer side, turned so that the line from the detector's right-eye key point to its
  left-eye key point is horizontal in the crop (``rotation = -atan2(-(y1 - y0), x1 - x0)``);
* the model (ImageToTensor, TensorsToLandmarks): the crop at 192x192, RGB in [0, 1]; 468 points
  (x, y, z) in input pixels, z on the x scale (smaller = nearer the camera); a face-presence logit
  whose sigmoid must reach 0.5;
* back to the photo (LandmarkProjection): through the crop's rotation and size, done in pixels.

Then a second pass (MediaPipe's tracking step, ``face_landmark_landmarks_to_roi.pbtxt``, run on the
same photo): a new crop around the landmarks' bounding box (1.5 times its longer side), turned by
the line through the eyes' outer corners (landmarks 33 and 263), and the model again. The
landmark model places points best on the crop it was trained with, which the detector's six key
points only approximate (a tilted head especially).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ..errors import NoFaceError
from .crop import Square
from .detection import FaceDetection, detect_faces
from .models import landmark_model
from .photo import Photo

__all__ = [
    "LEFT_EYE_OUTER",
    "NOSE_TIP",
    "RIGHT_EYE_OUTER",
    "FaceLandmarks",
    "crop_from_detection",
    "crop_from_landmarks",
    "face_landmarks",
    "find_face",
    "landmarks_of_face",
]

LANDMARK_INPUT_SIZE = 192
ROI_SCALE = 1.5
MIN_PRESENCE = 0.5
# MediaPipe's landmark numbers (the subject's sides): the outer eye corners and the tip of the nose (pronasale,
# the point of the canonical face nearest the viewer; 1, often called the nose tip, is just below it)
RIGHT_EYE_OUTER = 33
LEFT_EYE_OUTER = 263
NOSE_TIP = 4


@dataclass(frozen=True)
class FaceLandmarks:
    """The landmark model's answer for one face, in the photo's pixels.

    Parameters
    ----------
    points : numpy.ndarray
        ``(468, 3)`` float64: x right, y down, z on the x scale, smaller = nearer the camera
        (MediaPipe's convention, relative to the face's centre).
    presence : float
        The model's face-presence probability on its last crop.
    crop : Square
        The crop the model saw last.
    detection : FaceDetection
        The detector's face it started from.

    Examples
    --------
    >>> from skimage import data
    >>> marks = face_landmarks(data.astronaut())
    >>> marks.points.shape, round(marks.presence, 3), 100 < marks.crop.size < 200, marks.detection.score > 0.9
    ((468, 3), 1.0, True, True)
    """

    points: np.ndarray
    presence: float
    crop: Square
    detection: FaceDetection


def _run(photo: Photo, crop: Square) -> tuple[np.ndarray, float]:
    tensor = crop.sample(photo.rgb, LANDMARK_INPUT_SIZE, outside="nearest") / 255.0
    outputs = landmark_model()(tensor[None])
    raw = next(o for o in outputs if o.size == 468 * 3).reshape(468, 3).astype(np.float64) / LANDMARK_INPUT_SIZE
    logit = float(next(o for o in outputs if o.size == 1).ravel()[0])
    points = np.empty((468, 3))
    points[:, :2] = crop.to_photo(raw[:, :2])
    points[:, 2] = raw[:, 2] * crop.size
    return points, 1.0 / (1.0 + np.exp(-np.clip(logit, -100, 100)))


def _square(center: np.ndarray, width: float, height: float, start: np.ndarray, end: np.ndarray) -> Square:
    rotation = -np.arctan2(-(end[1] - start[1]), end[0] - start[0])
    return Square((float(center[0]), float(center[1])), ROI_SCALE * max(width, height), float(rotation))


def crop_from_detection(face: FaceDetection) -> Square:
    """The crop MediaPipe gives the landmark model for a detected face."""
    lo, hi = face.box[:2], face.box[2:]
    width, height = hi - lo
    return _square((lo + hi) / 2, width, height, face.keypoints[0], face.keypoints[1])


def crop_from_landmarks(points: np.ndarray) -> Square:
    """The crop MediaPipe's tracking gives the landmark model around landmarks found before.

    The box is that of the points turned upright (MediaPipe's ``RectFromLandmarks`` after
    ``rotation``), so a tilted face gets a tight square too.
    """
    start, end = points[RIGHT_EYE_OUTER, :2], points[LEFT_EYE_OUTER, :2]
    rotation = -np.arctan2(-(end[1] - start[1]), end[0] - start[0])
    c, s = np.cos(rotation), np.sin(rotation)
    upright = points[:, :2] @ np.array([[c, -s], [s, c]])  # the points in the crop's axes
    lo, hi = upright.min(axis=0), upright.max(axis=0)
    center = ((lo + hi) / 2) @ np.array([[c, s], [-s, c]])
    return Square((float(center[0]), float(center[1])), ROI_SCALE * float(max(hi - lo)), float(rotation))


def face_landmarks(
    photo: str | os.PathLike[str] | np.ndarray | Photo, *, index: int = 0, refine: bool = True
) -> FaceLandmarks:
    """The 468 landmarks of one face of a photo.

    Parameters
    ----------
    photo : path, ``(H, W, 3)`` uint8 array (grey or RGBA too), or :class:`~ffd_notebook.face.photo.Photo`
        The photo.
    index : int
        Which face, counted from the largest (0).
    refine : bool
        Run the model a second time on a crop placed by its first answer (see the module's notes).

    Returns
    -------
    FaceLandmarks
        The face's 468 points, the model's presence probability, its last crop and the detection.

    Raises
    ------
    NoFaceError
        If the detector finds no face (or fewer than ``index + 1``), or the landmark model does not
        see a face in the crop.

    Examples
    --------
    >>> from skimage import data
    >>> marks = face_landmarks(data.astronaut())
    >>> marks.points.shape, marks.presence > 0.99
    ((468, 3), True)
    >>> bool(marks.points[LEFT_EYE_OUTER, 0] > marks.points[RIGHT_EYE_OUTER, 0])   # her left eye: photo's right
    True
    """
    photo = Photo.of(photo)
    return landmarks_of_face(photo, find_face(photo, index=index), refine=refine)


def find_face(photo: Photo, *, index: int = 0) -> FaceDetection:
    """The ``index``-th largest face the detector finds, or :class:`~ffd_notebook.errors.NoFaceError`."""
    faces = detect_faces(photo)
    if not faces:
        raise NoFaceError(photo.name, "no face found in the photo")
    if not -len(faces) <= index < len(faces):
        raise NoFaceError(photo.name, f"face index {index} asked for, but only {len(faces)} face(s) found")
    return faces[index]


def landmarks_of_face(photo: Photo, face: FaceDetection, *, refine: bool = True) -> FaceLandmarks:
    """The landmark model on a face the detector found (see :func:`face_landmarks`)."""
    crop = crop_from_detection(face)
    points, presence = _run(photo, crop)
    if refine and presence >= MIN_PRESENCE:
        crop = crop_from_landmarks(points)
        points, presence = _run(photo, crop)
    if presence < MIN_PRESENCE:
        raise NoFaceError(
            photo.name,
            f"the detector found a face (score {face.score:.2f}) but the landmark model sees none there "
            f"(presence {presence:.2f} < {MIN_PRESENCE})",
        )
    return FaceLandmarks(points, float(presence), crop, face)
