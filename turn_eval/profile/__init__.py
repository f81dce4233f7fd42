"""Per-participant turning profiles and PD-versus-control contrasts (``turn-eval profile``).

From detected turns (``turn-eval detect``) of whole days at home to what a clinician or a trial
statistician reads: one row of turning measures per participant (``profile.csv``), turns per
local hour (``by_hour.csv``) and the two groups' contrasts with bootstrap intervals
(``contrasts.csv``). :mod:`~turn_eval.profile.inputs` reads and cross-checks,
:mod:`~turn_eval.profile.measures` and :mod:`~turn_eval.profile.contrasts` compute,
:mod:`~turn_eval.profile.plots` draws, :mod:`~turn_eval.profile.run` ties them together.
"""

from turn_eval.profile.contrasts import CONTRAST_COLUMNS, contrasts_table, group_stats
from turn_eval.profile.inputs import ProfileInputs, read_inputs
from turn_eval.profile.measures import BY_HOUR_COLUMNS, by_hour_table, profile_table
from turn_eval.profile.run import ProfileResult, turning_profile

__all__ = [
    "BY_HOUR_COLUMNS",
    "CONTRAST_COLUMNS",
    "ProfileInputs",
    "ProfileResult",
    "by_hour_table",
    "contrasts_table",
    "group_stats",
    "profile_table",
    "read_inputs",
    "turning_profile",
]
