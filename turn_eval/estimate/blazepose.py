"""MediaPipe Pose (BlazePose GHUM), run offline on CPU with the model inside the wheel.

Only ``mediapipe==0.10.21``'s legacy ``mediapipe.solutions.pose`` with
``model_complexity=1`` runs without a network: its wheel carries
``pose_detection.tflite`` and ``pose_landmark_full.tflite``; complexities 0 and 2 (the
``lite`` and ``heavy`` landmark models) are fetched from the internet on first use, and
mediapipe 0.10.30 and later carry no model at all. So the complexity is fixed at 1 and the
model file is checked to be present *before* MediaPipe is asked to build the graph: nothing
is ever downloaded.

mediapipe is the optional ``video`` extra (``pip install 'turnbench[video]'``); without it,
:func:`load_mediapipe` raises a one-line :class:`TurnbenchError` saying how to install it.

Per frame MediaPipe gives 33 *world* landmarks (metres, origin between the hips, x to the
image's right, y down, z away from the camera) and 33 *image* landmarks (x and y as
fractions of the image's width and height), or nothing when no person is found.
"""

from __future__ import annotations

import os
import re
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

import numpy as np

from turn_datasets.errors import TurnbenchError
from turn_datasets.params import param

__all__ = ["BUNDLED_MODELS", "MEDIAPIPE_VERSION", "PoseParams", "BlazePose", "load_mediapipe"]

#: The release whose wheel carries the pose model (the ``video`` extra pins it).
MEDIAPIPE_VERSION = "0.10.21"
#: The model files (inside the mediapipe package) that model_complexity=1 loads.
BUNDLED_MODELS = (
    "modules/pose_detection/pose_detection.tflite",
    "modules/pose_landmark/pose_landmark_full.tflite",
)
INSTALL_HINT = (
    f"install the video extra: pip install 'turnbench[video]' (mediapipe=={MEDIAPIPE_VERSION})"
)


@dataclass(frozen=True)
class PoseParams:
    """MediaPipe Pose's own settings (its defaults), as the legacy solution names them."""

    #: 1 (the "full" model) is the only complexity whose model is in the wheel.
    model_complexity: int = 1
    min_detection_confidence: float = param(
        0.5,
        "Confidence (0 to 1) of a person detection to start tracking (MediaPipe's).",
        min=0.0,
        max=1.0,
    )
    min_tracking_confidence: float = param(
        0.5,
        "Confidence (0 to 1) of the landmarks to keep tracking instead of detecting again "
        "(MediaPipe's).",
        min=0.0,
        max=1.0,
    )
    #: MediaPipe's one-euro filter over frames; the turning angle wants it (less jitter).
    smooth_landmarks: bool = True

    def __post_init__(self) -> None:
        if self.model_complexity != 1:
            raise TurnbenchError(
                f"model_complexity={self.model_complexity} would download its model from the "
                "internet; only 1 (pose_landmark_full, bundled in mediapipe's wheel) runs offline"
            )
        for name in ("min_detection_confidence", "min_tracking_confidence"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise TurnbenchError(f"{name} must be between 0 and 1, got {value}")


def load_mediapipe() -> ModuleType:
    """Import mediapipe and check that its wheel carries the pose model (module docstring)."""
    try:
        import mediapipe
    except ImportError:
        raise TurnbenchError(
            "`turn-eval estimate` needs mediapipe, which is not installed", hint=INSTALL_HINT
        ) from None
    root = Path(mediapipe.__file__).parent
    missing = [m for m in BUNDLED_MODELS if not (root / m).is_file()]
    if missing:
        version = getattr(mediapipe, "__version__", "unknown")
        raise TurnbenchError(
            f"mediapipe {version} does not carry the pose model {missing[0]} (it would "
            "download it)",
            hint=INSTALL_HINT,
        )
    return mediapipe


#: What MediaPipe's C++ side prints on a good run, line by line: absl's INFO and WARNING
#: lines (``W0000 00:00:1795679640.942330    7024 landmark_projection_calculator.cc:186]
#: Using NORM_RECT without IMAGE_DIMENSIONS ...``, logged at the first frame with a person,
#: however late in the video), TFLite's delegate line and absl's note before its set-up.
NATIVE_CHATTER = re.compile(
    r"^(?:[IW]\d{4} [\d:.]+\s+\d+ [\w.]+:\d+\] "
    r"|INFO: Created TensorFlow Lite"
    r"|WARNING: All log messages before absl::InitializeLog\(\) is called)"
)


def without_chatter(text: str) -> str:
    """``text`` without the lines :data:`NATIVE_CHATTER` matches (errors are kept)."""
    return "".join(
        line for line in text.splitlines(keepends=True) if not NATIVE_CHATTER.match(line)
    )


class _HeldNativeStderr:
    """MediaPipe's C++ libraries write straight to file descriptor 2, past ``sys.stderr``
    and past any log level: set-up chatter, and a warning at the first frame where a person
    is found, which may come at any time. File descriptor 2 is held in a temporary file for
    the whole tracking session; at its end the held text is written out without the
    :data:`NATIVE_CHATTER` lines (its errors stay, and so does anything else written
    meanwhile). A command's progress bar draws meanwhile on its own duplicate of the
    terminal's descriptor."""

    def __init__(self) -> None:
        sys.stderr.flush()
        self._file = tempfile.TemporaryFile()
        self._saved: int | None = os.dup(2)
        os.dup2(self._file.fileno(), 2)

    def release(self) -> None:
        if self._saved is None:
            return
        sys.stderr.flush()
        os.dup2(self._saved, 2)
        os.close(self._saved)
        self._saved = None
        self._file.seek(0)
        text = self._file.read().decode("utf-8", errors="replace")
        self._file.close()
        shown = without_chatter(text)
        if shown:
            sys.stderr.write(shown)
            sys.stderr.flush()


class BlazePose:
    """One tracking session of MediaPipe Pose over the frames of one video, in order.

    Use as a context manager; :meth:`process` takes an RGB ``(H, W, 3)`` uint8 frame and
    returns ``(world (33, 3), image (33, 2), visibility (33,))`` float arrays, NaN when
    nobody is found.
    """

    def __init__(self, params: PoseParams | None = None) -> None:
        self.params = params or PoseParams()
        mp = load_mediapipe()
        self.version = str(getattr(mp, "__version__", "unknown"))
        self._held: _HeldNativeStderr | None = _HeldNativeStderr()
        try:
            self._pose = mp.solutions.pose.Pose(
                static_image_mode=False,
                model_complexity=self.params.model_complexity,
                smooth_landmarks=self.params.smooth_landmarks,
                enable_segmentation=False,
                min_detection_confidence=self.params.min_detection_confidence,
                min_tracking_confidence=self.params.min_tracking_confidence,
            )
        except BaseException:
            self._release()
            raise

    def _release(self) -> None:
        if self._held is not None:
            self._held.release()
            self._held = None

    def __enter__(self) -> BlazePose:
        return self

    def __exit__(self, *exc: object) -> None:
        try:
            self._pose.close()  # it may log as it closes: still held
        finally:
            self._release()

    def process(self, rgb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        result = self._pose.process(rgb)
        if result.pose_world_landmarks is None or result.pose_landmarks is None:
            return np.full((33, 3), np.nan), np.full((33, 2), np.nan), np.full(33, np.nan)
        world = np.array(
            [(lm.x, lm.y, lm.z) for lm in result.pose_world_landmarks.landmark], dtype=np.float64
        )
        image = np.array([(lm.x, lm.y) for lm in result.pose_landmarks.landmark], dtype=np.float64)
        visibility = np.array(
            [lm.visibility for lm in result.pose_landmarks.landmark], dtype=np.float64
        )
        return world, image, visibility
