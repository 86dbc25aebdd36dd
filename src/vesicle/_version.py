"""The package version, in one place (every output file and JSON records it).

A module of its own so that the layers below the package's ``__init__`` can read it without
importing the package back."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("vesicle")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0+unknown"

__all__ = ["__version__"]
