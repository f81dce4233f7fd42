"""What every scorer of the harness shares: clips (``score``, ``compare``) and events
(``score-events``).

- :mod:`~turn_eval.scoring.table`: the one reader of user tables, with each row's line number;
- :mod:`~turn_eval.scoring.groups`: group labels;
- :mod:`~turn_eval.scoring.bootstrap`: seeded draws, the unit-resampling engine (additive
  components per unit and one combining function), percentile intervals;
- :mod:`~turn_eval.scoring.figures`: how a figure is written.
"""
