"""``python -m vesicle``: the command line, as ``vesicle``."""

from .cli import main

if __name__ == "__main__":
    main()
