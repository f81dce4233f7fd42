"""The demo (``make demo``, ``python -m turn_eval.demo --out-dir demo-output``): everything
turnbench does, on the bundled synthetic corpus, in one run; one module per stage.

- :mod:`turn_eval.demo.run`: the corpus, Turn-H3.6M, Turn-REMAP, predictions, scores and
  comparisons, the report page, and the command line;
- :mod:`turn_eval.demo.untrimmed`: untrimmed sessions (``detect``, ``score-events``);
- :mod:`turn_eval.demo.profile`: turning profiles (``profile``);
- :mod:`turn_eval.demo.remap_open`: Turn-REMAP as released (``remap open``);
- :mod:`turn_eval.demo.results`: the README's block of the demo's figures
  (``python -m turn_eval.demo.results demo-output README.md``).
"""

from turn_eval.demo.run import (
    DemoFailed,
    DemoResults,
    SetScores,
    load_results,
    main,
    match_planted,
    prepare_out_dir,
    run_demo,
    write_report,
)

__all__ = [
    "DemoFailed",
    "DemoResults",
    "SetScores",
    "load_results",
    "main",
    "match_planted",
    "prepare_out_dir",
    "run_demo",
    "write_report",
]
