"""A scoring server for hidden references: teams, quotas, a public/private split, signed
receipts and a significance-gated leaderboard (``turn-eval serve``, ``turn-eval server ...``).

A challenge lives in one data directory (:mod:`turn_eval.server.datadir`): the settings, a
private copy of the reference and its recorded public/private split, the server secret, the
uploads (each stored under its id) and, unless a PostgreSQL URL is given, the SQLite database.

The modules that need the ``server`` extra (FastAPI, uvicorn, SQLAlchemy, Jinja2,
python-multipart) are :mod:`~turn_eval.server.store`, :mod:`~turn_eval.server.app` and
:mod:`~turn_eval.server.service`; :mod:`~turn_eval.server.split`,
:mod:`~turn_eval.server.receipts`, :mod:`~turn_eval.server.datadir`,
:mod:`~turn_eval.server.scoring` and :mod:`~turn_eval.server.ranking` need only the core, and
nothing outside this package imports any of them, so ``turn-eval score`` never loads a web
framework.

The shape follows the hosted challenges that keep their references hidden (EvalAI,
Codabench, Kaggle): per-team daily and total quotas taken in one database transaction, a
per-object permission check on every submission read, baselines shown with a badge, and a
private split revealed only when the phase closes, with coarse, significance-gated ranks
against leaderboard climbing (Blum and Hardt 2015, "The Ladder: A reliable leaderboard for
machine learning competitions").
"""

#: What a missing ``server`` extra says.
EXTRA_HINT = "install the server extra: pip install 'turnbench[server]'"
