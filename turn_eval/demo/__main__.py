"""``python -m turn_eval.demo``: the demo's command line (:func:`turn_eval.demo.run.main`)."""

import sys

from turn_eval.demo.run import main

sys.exit(main())
