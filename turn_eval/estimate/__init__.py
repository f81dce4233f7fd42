"""Video to skeleton, offline (MediaPipe's bundled BlazePose), and other estimators' 3D files.

- :mod:`~turn_eval.estimate.pipeline`: ``estimate_video`` / ``write_estimate``, the chain
  behind ``turn-eval estimate``, and ``skeletons_from_landmarks``, its steps after decoding.
- :mod:`~turn_eval.estimate.batch`: ``estimate_videos``, many videos serially or on Dask,
  resumable, with the run manifest.
- :mod:`~turn_eval.estimate.joints`: BlazePose's 33 landmarks to Human3.6M's 17 joints.
- :mod:`~turn_eval.estimate.timing`: constant and variable frame rates onto a regular grid.
- :mod:`~turn_eval.estimate.guard`: where the single-person tracker jumps to someone else.
- :mod:`~turn_eval.estimate.tilt`: the camera's tilt removed, from the floor's normal.
- :mod:`~turn_eval.estimate.formats`: Strided Transformer, VideoPose3D and MotionBERT
  output files read by name (AlphaPose's 2D JSON refused).
- :mod:`~turn_eval.estimate.blazepose`, :mod:`~turn_eval.estimate.video`,
  :mod:`~turn_eval.estimate.preview`: MediaPipe, ffmpeg decoding, the QA preview.

Only ``blazepose`` needs the optional ``video`` extra (mediapipe), and only when run.
"""

from turn_eval.estimate.batch import RUN_MANIFEST, VideoJob, estimate_videos
from turn_eval.estimate.formats import ESTIMATOR_FORMATS, FORMAT_CHOICES, read_estimator_output
from turn_eval.estimate.guard import IdentityBreak, IdentityGuardParams, identity_breaks, tracks
from turn_eval.estimate.joints import (
    BLAZEPOSE_LANDMARKS,
    H36M17_FROM_BLAZEPOSE,
    blazepose_to_h36m17,
)
from turn_eval.estimate.pipeline import (
    AXES,
    EstimateParams,
    SkeletonEstimate,
    estimate_video,
    manifest_path,
    skeletons_from_landmarks,
    write_estimate,
)
from turn_eval.estimate.tilt import Levelling, LevelParams, estimate_up, level
from turn_eval.estimate.timing import TimeGrid, nominal_rate_hz, regular_grid, resample

__all__ = [
    "AXES",
    "RUN_MANIFEST",
    "VideoJob",
    "estimate_videos",
    "BLAZEPOSE_LANDMARKS",
    "ESTIMATOR_FORMATS",
    "FORMAT_CHOICES",
    "H36M17_FROM_BLAZEPOSE",
    "EstimateParams",
    "IdentityBreak",
    "IdentityGuardParams",
    "LevelParams",
    "Levelling",
    "SkeletonEstimate",
    "TimeGrid",
    "blazepose_to_h36m17",
    "estimate_up",
    "estimate_video",
    "identity_breaks",
    "level",
    "manifest_path",
    "nominal_rate_hz",
    "read_estimator_output",
    "regular_grid",
    "resample",
    "skeletons_from_landmarks",
    "tracks",
    "write_estimate",
]
