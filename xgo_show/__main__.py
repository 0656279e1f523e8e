"""``python -m xgo_show`` runs the CLI."""

import sys

from xgo_show.cli.main import main

sys.exit(main())
