import functools
import os
import pathlib
import re
from typing import Any

import pytest

REPO = pathlib.Path(__file__).resolve().parent.parent
# shared/ sits beside the checkout (../shared); tests that read the original facts skip without it.
SHARED = pathlib.Path(os.environ.get("BUILDHAT_SHARED", REPO.parent / "shared"))


@pytest.fixture(scope="session")
def shared_dir() -> pathlib.Path:
    if not SHARED.is_dir():
        pytest.skip(f"shared/ not found at {SHARED} (set BUILDHAT_SHARED)")
    return SHARED


# Under ``make test`` (pytest-xdist, ``--dist loadgroup``): a module that defines a module-scoped
# fixture (a whole suite run, a library matrix, a browser check) runs on one worker, so the fixture is
# computed once, not once per worker. Its own scheduler rather than xdist_group marks: xdist 3.8 puts
# the group into ``item._nodeid``, which pytest 9 no longer reads, so the marks group nothing.
_MODULE_FIXTURE = re.compile(r"@pytest\.fixture\(\s*scope=[\"']module[\"']")


@functools.cache
def _shares_a_module_fixture(path: str) -> bool:
    try:
        return bool(_MODULE_FIXTURE.search((REPO / path).read_text(encoding="utf-8")))
    except OSError:
        return False


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log: Any) -> Any:
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler import LoadGroupScheduling

    class ModuleFixtureScheduling(LoadGroupScheduling):
        def _split_scope(self, nodeid: str) -> str:
            path = nodeid.split("::", 1)[0]
            return path if _shares_a_module_fixture(path) else super()._split_scope(nodeid)

    return ModuleFixtureScheduling(config, log)
