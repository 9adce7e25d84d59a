"""The bundled MediaPipe models and the runtime that runs them (LiteRT, ``ai-edge-litert``).

Two ``.tflite`` files from the ``mediapipe`` 0.10.21 wheel on PyPI, unmodified, under their
Apache-2.0 licence (``data/LICENSE-mediapipe.txt``, ``data/NOTICE-mediapipe.txt``):

* ``face_detection_short_range.tflite``: BlazeFace, 128x128 RGB in [-1, 1] -> 896 anchor boxes
  (16 numbers each: box and six key points) and 896 score logits;
* ``face_landmark.tflite``: 192x192 RGB in [0, 1] -> 468 3D points (1,404 numbers, in input
  pixels) and one face-presence logit.

mediapipe itself is not a dependency (it pins NumPy < 2); LiteRT is. A loaded model is kept for
the process; LiteRT interpreters are not thread-safe, so each call holds the model's lock.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["DETECTOR_FILE", "LANDMARK_FILE", "LiteRTMissingError", "Model", "detector", "landmark_model"]

DATA = Path(__file__).parent / "data"
DETECTOR_FILE = DATA / "face_detection_short_range.tflite"
LANDMARK_FILE = DATA / "face_landmark.tflite"


class LiteRTMissingError(ImportError):
    """The TensorFlow Lite runtime is not installed: says what to install.

    Raised when a face model is first loaded, not on import, so that code without faces never needs LiteRT.

    Examples
    --------
    >>> try:
    ...     model = detector()
    ... except LiteRTMissingError as exc:  # no LiteRT wheel for this platform: say so, go on without faces
    ...     model = None
    ...     print(exc)
    >>> model.input_shape
    (1, 128, 128, 3)
    """


def _interpreter_class() -> Any:
    try:
        from ai_edge_litert.interpreter import Interpreter
    except ImportError as exc:  # no wheel for this platform, or a broken install
        raise LiteRTMissingError(
            "face_from_photo runs MediaPipe's face models with LiteRT, which is not installed: "
            "install ai-edge-litert (python -m pip install ai-edge-litert; wheels exist for Linux x86-64, "
            f"macOS arm64 and Windows). Import failed with: {exc}"
        ) from exc
    return Interpreter


def _builtin_kernels() -> Any:
    from ai_edge_litert.interpreter import OpResolverType

    return OpResolverType.BUILTIN_WITHOUT_DEFAULT_DELEGATES


@dataclass
class Model:
    """One loaded ``.tflite`` model: ``model(x)`` runs it on one input array and returns its outputs."""

    path: Path
    interpreter: Any
    input_shape: tuple[int, ...]
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    @classmethod
    def load(cls, path: Path) -> Model:
        # LiteRT's default XNNPACK delegate prints "INFO: Created TensorFlow Lite XNNPACK delegate for CPU." on
        # the process's stderr (no setting silences it; it stood in the face notebook's output). Without it a
        # 512 px face takes 86 ms instead of 48 (detection 9 ms instead of 4, landmarks 26 instead of 11;
        # tests/benchmarks/bench_face.py), against a target of 1 s.
        interpreter = _interpreter_class()(
            model_path=str(path), num_threads=1, experimental_op_resolver_type=_builtin_kernels()
        )
        interpreter.allocate_tensors()
        (inp,) = interpreter.get_input_details()
        return cls(path, interpreter, tuple(int(n) for n in inp["shape"]))

    def __call__(self, x: np.ndarray) -> list[np.ndarray]:
        x = np.ascontiguousarray(x, dtype=np.float32).reshape(self.input_shape)
        with self._lock:
            it = self.interpreter
            it.set_tensor(it.get_input_details()[0]["index"], x)
            it.invoke()
            return [it.get_tensor(d["index"]).copy() for d in it.get_output_details()]


@lru_cache(maxsize=1)
def detector() -> Model:
    """The face detector (BlazeFace short range), loaded once per process."""
    return Model.load(DETECTOR_FILE)


@lru_cache(maxsize=1)
def landmark_model() -> Model:
    """The face landmark model (468 points), loaded once per process."""
    return Model.load(LANDMARK_FILE)
