"""``python -m flexhrc`` is the same as the ``flexhrc`` command."""

import sys

from flexhrc.cli import main

sys.exit(main())
