"""Command-line interface (filled in by the orchestration work)."""
import sys


def main(argv=None) -> int:
    print("anklehip: not built yet", file=sys.stderr)
    return 1
