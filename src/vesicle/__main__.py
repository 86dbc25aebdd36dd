"""``python -m vesicle``: the command line, as ``vesicle``."""

from vesicle.cli import main

if __name__ == "__main__":
    main()
