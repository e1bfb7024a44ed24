"""Entry point: `python3 analysis/hysid_plots ...` (a directory run) or `python3 -m hysid_plots ...`."""
import os
import sys

if not __package__:  # run as a directory: make the package importable by its name
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from hysid_plots.cli import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main())
