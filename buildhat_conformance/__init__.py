"""buildhat-conformance: conformance suite, fuzzer and reference emulator for the Build HAT."""
from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("buildhat-conformance")
except PackageNotFoundError:  # a plain checkout that was never installed
    __version__ = "0+unknown"
