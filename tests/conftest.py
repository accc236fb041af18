import os
import pathlib

import pytest

REPO = pathlib.Path(__file__).resolve().parent.parent
# shared/ sits beside the checkout (../shared); tests that read the original facts skip without it.
SHARED = pathlib.Path(os.environ.get("BUILDHAT_SHARED", REPO.parent / "shared"))


@pytest.fixture(scope="session")
def shared_dir() -> pathlib.Path:
    if not SHARED.is_dir():
        pytest.skip(f"shared/ not found at {SHARED} (set BUILDHAT_SHARED)")
    return SHARED
