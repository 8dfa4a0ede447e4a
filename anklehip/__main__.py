"""``python -m anklehip ...``: the same as the ``anklehip`` command (console script anklehip.cli:main)."""
from .cli import main

raise SystemExit(main())
