"""``python -m autocable.cli ...``: the `autocable` command (subprocess runs of the benches and tests)."""
import sys

from autocable.cli import main

sys.exit(main())
