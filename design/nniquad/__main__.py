"""``python -m nniquad``: the command line."""

import sys

from nniquad.cli.main import main

if __name__ == "__main__":
    sys.exit(main())
