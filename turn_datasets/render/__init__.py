"""Presentation shared by every output of turnbench: numbers, metric labels, Markdown tables.

One rounding rule (:func:`~turn_datasets.render.numbers.fixed`: half up on the shortest
decimal form, as a reader rounds a printed table), one table of metric labels
(:data:`~turn_datasets.render.labels.METRIC_LABELS`), one Markdown table writer
(:func:`~turn_datasets.render.markdown.markdown_table`) and one sort order of names
(:func:`~turn_datasets.render.order.natural_key`), so that the same number reads the same in
scores.md, report.html, the statistics tables and the agreement audit.
"""
