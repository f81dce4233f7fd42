"""BlazePose's 33 landmarks to Human3.6M's 17 joints, the layout the rest of turnbench reads.

MediaPipe Pose (BlazePose GHUM) returns 33 landmarks; Human3.6M's 17-joint skeleton (the
order of 3d-pose-baseline, VideoPose3D, Strided Transformer and MotionBERT, and of
:data:`turn_datasets.skeleton.H36M17`) has joints BlazePose does not: the pelvis, spine,
thorax and head. They are built as means of landmarks:

====  ==============  ==============================================================
H17   joint           BlazePose landmarks (index: name)
====  ==============  ==============================================================
0     pelvis          mean of 23 left_hip, 24 right_hip (MediaPipe's world origin)
1     right_hip       24 right_hip
2     right_knee      26 right_knee
3     right_foot      28 right_ankle (Human3.6M's "foot" joint is the ankle)
4     left_hip        23 left_hip
5     left_knee       25 left_knee
6     left_foot       27 left_ankle
7     spine           mean of 11, 12, 23, 24 (midway between pelvis and thorax)
8     thorax          mean of 11 left_shoulder, 12 right_shoulder
9     neck            0 nose (the joint Human3.6M's 17-joint files call "Neck/Nose")
10    head            mean of 7 left_ear, 8 right_ear (the head's centre; Human3.6M's
                      joint is the crown, a few centimetres higher)
11    left_shoulder   11 left_shoulder
12    left_elbow      13 left_elbow
13    left_wrist      15 left_wrist
14    right_shoulder  12 right_shoulder
15    right_elbow     14 right_elbow
16    right_wrist     16 right_wrist
====  ==============  ==============================================================

Left and right are the person's own (BlazePose's and Human3.6M's convention alike), so the
left-minus-right hip vector of the paper's equations 1 and 2 keeps its meaning. The turning
angle uses only the hips; the approximations of the head and spine do not reach it.
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

from turn_datasets.errors import TurnbenchError
from turn_datasets.skeleton import H36M17

__all__ = ["BLAZEPOSE_LANDMARKS", "H36M17_FROM_BLAZEPOSE", "blazepose_to_h36m17"]

#: BlazePose's 33 landmark names, in MediaPipe's index order.
BLAZEPOSE_LANDMARKS = (
    "nose",
    "left_eye_inner",
    "left_eye",
    "left_eye_outer",
    "right_eye_inner",
    "right_eye",
    "right_eye_outer",
    "left_ear",
    "right_ear",
    "mouth_left",
    "mouth_right",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_pinky",
    "right_pinky",
    "left_index",
    "right_index",
    "left_thumb",
    "right_thumb",
    "left_hip",
    "right_hip",
    "left_knee",
    "right_knee",
    "left_ankle",
    "right_ankle",
    "left_heel",
    "right_heel",
    "left_foot_index",
    "right_foot_index",
)

#: Human3.6M 17-joint name -> the BlazePose landmark indices averaged into it (table above).
H36M17_FROM_BLAZEPOSE = MappingProxyType(
    {
        "pelvis": (23, 24),
        "right_hip": (24,),
        "right_knee": (26,),
        "right_foot": (28,),
        "left_hip": (23,),
        "left_knee": (25,),
        "left_foot": (27,),
        "spine": (11, 12, 23, 24),
        "thorax": (11, 12),
        "neck": (0,),
        "head": (7, 8),
        "left_shoulder": (11,),
        "left_elbow": (13,),
        "left_wrist": (15,),
        "right_shoulder": (12,),
        "right_elbow": (14,),
        "right_wrist": (16,),
    }
)


def blazepose_to_h36m17(landmarks: np.ndarray) -> np.ndarray:
    """``(frames, 33, C)`` BlazePose landmarks -> ``(frames, 17, C)`` in Human3.6M's order.

    Works for world landmarks (C = 3, metres) and image landmarks (C = 2) alike; a frame of
    NaN stays NaN. The result is float64, whatever the input's float type.
    """
    lm = np.asarray(landmarks, dtype=np.float64)
    if lm.ndim != 3 or lm.shape[1] != len(BLAZEPOSE_LANDMARKS):
        raise TurnbenchError(
            f"BlazePose landmarks must have shape (frames, 33, C), got {tuple(lm.shape)}"
        )
    out = np.empty((lm.shape[0], H36M17.n_joints, lm.shape[2]), dtype=np.float64)
    for name, sources in H36M17_FROM_BLAZEPOSE.items():
        out[:, H36M17.index(name)] = lm[:, list(sources)].mean(axis=1)
    return out
