"""What every scorer of the harness shares: clips (``score``, ``compare``) and events
(``score-events``).

- :mod:`~turn_eval.scoring.groups`: group labels;
- :mod:`~turn_eval.scoring.bootstrap`: seeded draws, the unit-resampling engine (additive
  components per unit and one combining function), percentile intervals;
- :mod:`~turn_eval.scoring.figures`: how a figure is written.

The one reader of user tables with line numbers is :mod:`turn_datasets.usertable`: the
curation's readers (clip index, overrides, participants) use it too, and ``turn_datasets``
never imports ``turn_eval``.
"""
