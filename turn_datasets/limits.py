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
    "MAX_POSITION_ABS",
    "MAX_ARRAY_VALUES",
    "MAX_PICKLE_OPCODES",
    "MAX_LOCAL_WORKERS",
    "MAX_TURN_DURATION_S",
    "MAX_TURN_MEAN_SPEED_DEG_S",
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
#: Largest coordinate a skeleton may hold, in any length unit: a billion is 1,000 km in
#: millimetres and far beyond any pixel grid. Beyond it a value is corrupt or in the wrong
#: unit, and the geometry breaks down: squared lengths overflow float64 near 1e154 (at
#: 1e150 every turn vanished; at 1e300 the rule stopped with an OverflowError).
MAX_POSITION_ABS = 1e9
#: Most values one skeleton array may declare (frames x joints x 3): 2**28, 1 GiB as
#: float32. A 17-joint stream at 30 fps holds 48 hours, a 32-joint one at 50 Hz 15; a
#: longer recording is split into files (one per day or session). Checked, with the
#: machine's free memory, before anything is read: a few kilobytes of gzip-compressed HDF5
#: can declare 40 million frames (8 GB).
MAX_ARRAY_VALUES = 2**28
#: Most opcodes the one pickle turnbench reads (VideoPose3D's ``positions_3d`` dict) may
#: hold. Its writer spends 27 a sequence (Human3.6M's 210 sequences about 5,700); each opcode
#: builds at most one Python object of a few hundred bytes besides the bytes it carries, so
#: 2**20 keep what unpickling builds beyond its arrays to a few hundred MB, where a crafted
#: pickle of empty lists builds 64 bytes of objects for every byte it inflates to.
MAX_PICKLE_OPCODES = 2**20
#: Most worker processes a local cluster (``--workers``) starts: one machine's. Each is
#: single-threaded and holds about 200 MB before any file, and more processes than cores run
#: no faster; 256 is already 51 GB. A bigger run belongs on a cluster (``--scheduler``).
MAX_LOCAL_WORKERS = 256

#: Longest single turn, seconds: El-Gohary et al. (2014, Sensors 14:356) and mobgap's
#: ``TdElGohary`` keep turns of 0.5-10 s; turning that goes on longer (walking round a loop,
#: circling) is an episode of several turns or of none, never one turn of 600°.
MAX_TURN_DURATION_S = 10.0
#: Fastest mean speed of a turn a person makes, degrees per second. Real turns in Human3.6M
#: run at 19-154 °/s on average; fast pivots reach a few hundred °/s at their peak, not on
#: average over the turn (El-Gohary et al. 2014; Shah et al. 2021). Twice the fastest real
#: mean: what is faster is a left/right swap, an identity break or a flip of the hip line.
MAX_TURN_MEAN_SPEED_DEG_S = 300.0
