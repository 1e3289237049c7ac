"""``python -m nniquad``: the command line."""

import sys

from nniquad.cli.main import main

sys.exit(main())
