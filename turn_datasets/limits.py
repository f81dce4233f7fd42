"""Plausibility bounds of every number turnbench reads or takes as an option, declared once.

A value outside these bounds is not a turn a person makes, nor a setting anyone means: it is
a typo, a unit mix-up or a hostile input, and left through it turns metrics into null or
overflows an integer (a 1e308 degree angle binned to -9223372036854775808). Readers refuse
such a value with its file and row, the command line refuses such an option, both with
exit 2. The README's error section states these numbers.
"""

from __future__ import annotations

__all__ = [
    "MAX_ANGLE_DEG",
    "MAX_SPEED_DEG_S",
    "MAX_FPS_HZ",
    "MIN_FPS_HZ",
    "MAX_DURATION_S",
    "MAX_BIN_WIDTH_DEG",
    "MAX_RESAMPLES",
    "MAX_SEED",
]

#: Ten full revolutions: no single turn of a person comes near it (the paper's largest
#: Turn-H3.6M clip is 234.7 degrees), yet spinning tests and unwrapped sums fit.
MAX_ANGLE_DEG = 3600.0
#: Degrees per second: a pirouette peaks near 2000; ten thousand is no human's.
MAX_SPEED_DEG_S = 10_000.0
#: Frame rates of motion capture and video: 1000 Hz systems exist; ten times that is a typo.
MAX_FPS_HZ = 10_000.0
#: Slowest frame rate a motion capture plausibly has: a BVH's "Frame Time: 100" (0.01 Hz) is
#: a unit mistake, and it mines nothing.
MIN_FPS_HZ = 1.0
#: Longest time span an option may take (a gap to bridge, a smoothing window): one hour.
MAX_DURATION_S = 3600.0
#: Widest angle bin: one revolution (every angle in one bin already).
MAX_BIN_WIDTH_DEG = 360.0
#: Bootstrap and permutation resamples: every one recomputes every metric, and 10^5 already
#: pins a 95% interval's ends to well under a tenth of a percentage point.
MAX_RESAMPLES = 100_000
#: NumPy's legacy seeds are 32-bit; keeping every seed there keeps runs reproducible anywhere.
MAX_SEED = 2**32 - 1
