"""``python -m anklehip.cli ...``: the same as the ``anklehip`` command."""
import sys

from . import main

sys.exit(main())
