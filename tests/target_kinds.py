"""``make_target`` with the kind of target a test relies on: the same URL (and entry point) a user
gives, then an assertion that it made that class, so the test may use what only that class has
(``proc``, ``child``, ``now``, ...) and the type checker knows it."""
from __future__ import annotations

from typing import Any, Type, TypeVar

from buildhat_conformance.harness.targets import make_target
from buildhat_conformance.harness.targets.base import Target

T = TypeVar("T", bound=Target)


def make_target_of(kind: Type[T], url: str, **options: Any) -> T:
    target = make_target(url, **options)
    assert isinstance(target, kind), f"{url} made a {type(target).__name__}, not a {kind.__name__}"
    return target
