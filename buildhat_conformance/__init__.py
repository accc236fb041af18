"""buildhat-conformance: conformance suite, fuzzer and reference emulator for the Build HAT."""
# The folders install under this package's name (setup.py); pyright reads the checkout.
# pyright: reportMissingImports=false
from .plumbing.package_version import __version__

__all__ = ["__version__"]
