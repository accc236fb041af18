"""Where the tests and the checkout are, for tests in any sub-folder of tests/ (their own
``__file__`` says only how deep they sit)."""
from __future__ import annotations

import pathlib

TESTS = pathlib.Path(__file__).resolve().parent
REPO = TESTS.parent
