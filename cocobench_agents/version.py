"""The package's version, in a module of its own so that the package's modules read it
without importing the package's `__init__` (which loads the Python API)."""

__version__ = "0.1.0"
