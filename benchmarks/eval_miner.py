"""Accuracy of the miner on issue 11's synthetic sets, in the three Human3.6M layouts.

The sets are :mod:`turn_datasets.synthetic.miner_sets`', the matching and the scores
:mod:`turn_datasets.h36m.evaluation`'s. Targets
(issue 11): easy, recall and precision 1.00, median angle error <= 1°, p90 <= 3°, median
boundary error <= 0.15 s; hard, recall and precision >= 0.98, median <= 2.5°, p90 <= 6°,
boundary <= 0.2 s.

Run: ``python benchmarks/eval_miner.py [--seeds N]``; prints one JSON line per set and layout.
"""

from __future__ import annotations

import argparse
import json

from turn_datasets.synthetic.miner_sets import LAYOUTS, SETS, score


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=40, help="sequences per set (8 turns each)")
    ap.add_argument("--layouts", default=",".join(LAYOUTS), help="comma-separated")
    ap.add_argument("--sets", default=",".join(SETS), help="comma-separated")
    args = ap.parse_args(argv)
    for set_name in args.sets.split(","):
        for layout in args.layouts.split(","):
            result = score(set_name, layout, range(args.seeds))
            result.pop("table")
            print(json.dumps(result), flush=True)


if __name__ == "__main__":
    main()
