"""Scoring trimmed clips (``turn-eval score``, ``turn-eval compare``).

- :mod:`~turn_eval.clips.submission`: the reference and the predictions, read and joined;
- :mod:`~turn_eval.clips.metrics`: the paper's metrics and their grouped bootstrap;
- :mod:`~turn_eval.clips.tables`: the scores document and its Markdown, CSV and JSON;
- :mod:`~turn_eval.clips.significance`: paired comparison of two submissions;
- :mod:`~turn_eval.clips.plots`: the figures of ``score --plots``.
"""
