"""``python -m turn_datasets``: the same as the console script."""

from turn_datasets.cli import main

main()
