"""``python -m turn_eval``: the same as the console script."""

from turn_eval.cli import main

main()
