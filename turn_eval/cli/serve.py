"""``turn-eval serve DIR``: run a challenge's scoring server (:mod:`turn_eval.server.app`).

Thin: open the data directory, build the app and its scorer, hand them to uvicorn.
"""

from __future__ import annotations

from pathlib import Path

import click

from turn_datasets.cli.common import CONTEXT_SETTINGS, Number, info
from turn_eval.cli import cli
from turn_eval.cli.server import DATA_DIR, needs_extra
from turn_eval.server.datadir import open_challenge


@cli.command("serve", context_settings=CONTEXT_SETTINGS)
@click.argument("root", metavar="DIR", type=DATA_DIR)
@click.option("--host", default="127.0.0.1", show_default=True, help="Address to listen on.")
@click.option(
    "--port",
    type=Number(int, min=1, max=65535),
    default=8000,
    show_default=True,
    help="Port to listen on.",
)
@click.option(
    "--workers",
    type=Number(int, min=1, max=64),
    default=2,
    show_default=True,
    help="Scoring worker processes.",
)
def serve(root: Path, host: str, port: int, workers: int) -> None:
    """Serve a challenge made by `turn-eval server init`: the API and the leaderboard page.

    POST /api/submissions (Authorization: Bearer TOKEN, multipart field 'file') queues a
    predictions CSV once `turn-eval score`'s validation accepts it; GET /api/submissions/ID,
    /api/receipts/ID, /api/leaderboard and / (the page). Stop it with Ctrl-C; whatever was
    queued is scored after the next start.

    \b
    Example:
      turn-eval serve challenge/ --port 8000
      curl -H "Authorization: Bearer $(cat team-a.token)" -F file=@predictions.csv \\
          http://127.0.0.1:8000/api/submissions
    """
    challenge = open_challenge(root)
    service = needs_extra("turn_eval.server.service")
    app_module = needs_extra("turn_eval.server.app")
    uvicorn = needs_extra("uvicorn")
    store = service.open_store(challenge)
    scorer = service.Scorer(challenge, store, workers=workers)
    app = app_module.create_app(challenge, store, scorer, service.Checker(challenge))
    config = uvicorn.Config(app, host=host, port=port, log_level="warning", access_log=False)
    server = uvicorn.Server(config)
    info(f"serving {challenge.name!r} from {root} on http://{host}:{port}/ (Ctrl-C stops)")
    server.run()
    info("stopped")
