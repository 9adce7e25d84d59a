"""Finding faces: MediaPipe's BlazeFace short-range detector, decoded as MediaPipe's own graph decodes it.

The numbers are those of ``mediapipe/modules/face_detection/face_detection_short_range.pbtxt`` and
``face_detection.pbtxt`` (MediaPipe 0.10.21), read with the calculators that use them:

* input: the whole photo letterboxed into 128x128 (``keep_aspect_ratio: true``, black border),
  RGB scaled to [-1, 1] (ImageToTensorCalculator);
* anchors (SsdAnchorsCalculator): strides 8, 16, 16, 16; layers of equal stride are merged, each
  layer giving two anchors per cell (aspect ratio 1 and the interpolated scale), so 16x16x2 +
  8x8x6 = 896 anchors; ``fixed_anchor_size: true`` makes every anchor 1x1 centred at
  ``((x + 0.5) / 16, (y + 0.5) / 16)`` or ``/ 8``;
* boxes (TensorsToDetectionsCalculator, ``reverse_output_order: true`` = x, y, w, h): centre =
  raw / 128 + anchor centre, size = raw / 128; six key points after the box as (x, y) pairs, also
  raw / 128 + anchor centre (right eye, left eye, nose tip, mouth, right ear, left ear: the subject's
  sides, so key point 0 is on the photo's left); score = sigmoid(logit clipped to +-100) >= 0.5;
* weighted non-maximum suppression (NonMaxSuppressionCalculator, ``WEIGHTED``, IoU > 0.3): each
  kept face is the score-weighted mean of the boxes and key points it absorbs.

A large photo is first shrunk by a whole factor (block means) to at most twice the detector's
input (:meth:`.Square.sample`), so it sees a large photo as it sees a small one; results are in
the full photo's pixels.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .crop import Square
from .models import detector
from .photo import Photo

__all__ = ["FaceDetection", "anchors", "detect_faces", "weighted_nms"]

DETECTOR_INPUT_SIZE = 128
STRIDES = (8, 16, 16, 16)
ANCHORS_PER_LAYER = 2  # aspect ratio 1.0 + interpolated_scale_aspect_ratio 1.0
SCORE_CLIP = 100.0
MIN_SUPPRESSION_IOU = 0.3


@dataclass(frozen=True)
class FaceDetection:
    """One face found by the detector, in the photo's pixels (x right, y down).

    Parameters
    ----------
    box : numpy.ndarray
        ``(xmin, ymin, xmax, ymax)``.
    keypoints : numpy.ndarray
        ``(6, 2)``: the subject's right eye, left eye, nose tip, mouth centre, right ear, left ear.
    score : float
        The detector's confidence in [0, 1].

    Examples
    --------
    >>> face = FaceDetection(np.array([10.0, 20.0, 50.0, 80.0]), np.zeros((6, 2)), 0.9)
    >>> face.area, face.score
    (2400.0, 0.9)
    """

    box: np.ndarray
    keypoints: np.ndarray
    score: float

    @property
    def area(self) -> float:
        """The box's area in square pixels."""
        return float((self.box[2] - self.box[0]) * (self.box[3] - self.box[1]))


@lru_cache(maxsize=1)
def anchors() -> np.ndarray:
    """Centres ``(896, 2)`` (x, y in [0, 1]) of the detector's anchors, in its output order.

    Examples
    --------
    >>> a = anchors()
    >>> a.shape, a[0].tolist(), a[1].tolist(), a[2].tolist()
    ((896, 2), [0.03125, 0.03125], [0.03125, 0.03125], [0.09375, 0.03125])
    >>> a[512].tolist(), bool((a[512:518] == a[512]).all())      # stride 16: six anchors per cell
    ([0.0625, 0.0625], True)
    """
    out = []
    layer = 0
    while layer < len(STRIDES):
        merged = layer
        while merged < len(STRIDES) and STRIDES[merged] == STRIDES[layer]:
            merged += 1
        per_cell = ANCHORS_PER_LAYER * (merged - layer)
        n = int(np.ceil(DETECTOR_INPUT_SIZE / STRIDES[layer]))
        y, x = np.meshgrid((np.arange(n) + 0.5) / n, (np.arange(n) + 0.5) / n, indexing="ij")
        cells = np.stack([x.ravel(), y.ravel()], axis=1)
        out.append(np.repeat(cells, per_cell, axis=0))
        layer = merged
    result = np.concatenate(out)
    result.setflags(write=False)
    return result


def _decode(regressors: np.ndarray, logits: np.ndarray, min_score: float) -> list[tuple[np.ndarray, float]]:
    """Boxes ``(xmin, ymin, xmax, ymax)`` + 6 key points, all in [0, 1] of the 128x128 input, and scores."""
    raw = regressors.reshape(-1, 16).astype(np.float64) / DETECTOR_INPUT_SIZE
    scores = 1.0 / (1.0 + np.exp(-np.clip(logits.reshape(-1).astype(np.float64), -SCORE_CLIP, SCORE_CLIP)))
    keep = np.flatnonzero(scores >= min_score)
    a = anchors()[keep]
    raw = raw[keep]
    centre = raw[:, 0:2] + a
    half = raw[:, 2:4] / 2
    keypoints = raw[:, 4:16].reshape(-1, 6, 2) + a[:, None, :]
    boxes = np.concatenate([centre - half, centre + half], axis=1)
    return [(np.concatenate([b, k.ravel()]), float(s)) for b, k, s in zip(boxes, keypoints, scores[keep], strict=True)]


def _iou(box: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    lo = np.maximum(box[:2], boxes[:, :2])
    hi = np.minimum(box[2:4], boxes[:, 2:4])
    inter = np.prod(np.clip(hi - lo, 0, None), axis=1)
    area = np.prod(box[2:4] - box[:2])
    areas = np.prod(boxes[:, 2:4] - boxes[:, :2], axis=1)
    union = area + areas - inter
    return np.where(union > 0, inter / np.where(union > 0, union, 1.0), 0.0)


def weighted_nms(candidates: list[tuple[np.ndarray, float]], iou: float = MIN_SUPPRESSION_IOU) -> list[tuple]:
    """MediaPipe's weighted non-maximum suppression of ``(values, score)`` pairs (values start with a box).

    The best remaining candidate absorbs every one that overlaps it by IoU > ``iou`` (itself
    included); the result keeps its score and takes the score-weighted mean of their values.

    Examples
    --------
    >>> a = (np.array([0.0, 0, 1, 1]), 0.9)
    >>> b = (np.array([0.1, 0, 1.1, 1]), 0.6)
    >>> c = (np.array([5.0, 5, 6, 6]), 0.7)
    >>> [(v.round(2).tolist(), s) for v, s in weighted_nms([a, b, c])]
    [([0.04, 0.0, 1.04, 1.0], 0.9), ([5.0, 5.0, 6.0, 6.0], 0.7)]
    """
    remaining = sorted(candidates, key=lambda c: -c[1])
    out = []
    while remaining:
        top_values, top_score = remaining[0]
        values = np.array([v for v, _ in remaining])
        scores = np.array([s for _, s in remaining])
        near = _iou(top_values[:4], values[:, :4]) > iou
        near[0] = True
        merged = (values[near] * scores[near, None]).sum(axis=0) / scores[near].sum()
        out.append((merged, top_score))
        remaining = [c for c, n in zip(remaining, near, strict=True) if not n]
    return out


def detect_faces(photo: str | os.PathLike[str] | np.ndarray | Photo, *, min_score: float = 0.5) -> list[FaceDetection]:
    """Faces in a photo, the largest first.

    Parameters
    ----------
    photo : path, ``(H, W, 3)`` uint8 array (grey or RGBA too), or :class:`~ffd_notebook.face.photo.Photo`
        The photo.
    min_score : float
        The detector's threshold (MediaPipe's ``min_score_thresh``, 0.5).

    Returns
    -------
    list of FaceDetection
        Possibly empty.

    Examples
    --------
    >>> from skimage import data
    >>> faces = detect_faces(data.astronaut())
    >>> len(faces), faces[0].score > 0.9
    (1, True)
    >>> [round(float(v)) for v in faces[0].box]       # xmin, ymin, xmax, ymax
    [178, 81, 272, 175]
    >>> detect_faces(data.coins())
    []
    """
    photo = Photo.of(photo)
    letterbox = Square((photo.width / 2, photo.height / 2), float(max(photo.width, photo.height)))
    tensor = letterbox.sample(photo.rgb, DETECTOR_INPUT_SIZE, outside="zero") * (2.0 / 255.0) - 1.0
    outputs = detector()(tensor[None])
    regressors = next(o for o in outputs if o.shape[-1] == 16)
    logits = next(o for o in outputs if o.shape[-1] == 1)
    faces = []
    for values, score in weighted_nms(_decode(regressors, logits, min_score)):
        points = letterbox.to_photo(values.reshape(-1, 2))  # box corners, then the key points
        faces.append(FaceDetection(points[:2].ravel(), points[2:], score))
    return sorted(faces, key=lambda f: -f.area)
