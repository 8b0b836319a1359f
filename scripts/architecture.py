"""Check flexhrc's layering and regenerate the package diagram of docs/architecture.md.

    python scripts/architecture.py --write    # rewrite the diagram between the markers
    python scripts/architecture.py --check    # exit 1: stale diagram, upward import or cycle
    python scripts/architecture.py --print    # the diagram on stdout

The layer table and the import graph live in ``src/flexhrc/_layers.py``; this runs it from a
checkout without installing anything (standard library only).
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "src"))

from flexhrc._layers import main

if __name__ == "__main__":
    sys.exit(main())
