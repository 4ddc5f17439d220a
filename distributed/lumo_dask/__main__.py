"""`python -m lumo_dask`: the same as the `lumo-dask` command."""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
