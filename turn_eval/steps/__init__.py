"""Steps, turn type and peak turning speed per turn, from 3D skeletons (``detect``, ``predict``).

:mod:`~turn_eval.steps.contacts` holds the rule and its thresholds (:class:`StepParams`).
"""

from turn_eval.steps.contacts import (
    STEP_COLUMNS,
    STEP_JOINTS,
    StepParams,
    foot_swings,
    turn_steps,
)

__all__ = ["STEP_COLUMNS", "STEP_JOINTS", "StepParams", "foot_swings", "turn_steps"]
