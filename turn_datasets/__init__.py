"""turn_datasets: curation of the Turn-H3.6M and Turn-REMAP turning benchmarks.

Skeleton geometry (the paper's equations 1 to 4), motion-capture readers, the turn miner,
ELAN label parsing and the inter-rater agreement audit. The public API is re-exported here;
see the submodules for details.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

from turn_datasets.errors import GateFailed, TurnbenchError

try:
    __version__ = version("turnbench")
except PackageNotFoundError:  # running from a source tree without installing
    __version__ = "0+unknown"

__all__ = ["GateFailed", "TurnbenchError", "__version__"]
