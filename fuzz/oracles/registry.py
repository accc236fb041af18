"""The fuzzer's oracles as one registry: each oracle is one :class:`Oracle` object (its name, its
priority, when it is a JUnit case, its check, the problems and the finding it reports, its help
text). The runner (fuzz/running/checked_run.py), the command line (``fuzz --help``) and the JUnit
file (fuzz/running/from_arguments.py) read them from here; the summary (fuzz/summary.py) prints the
checks and findings the runner counted under their names.

The fuzzer's own seven are declared in fuzz/oracles/built_in.py; their checks run where the runner
reads an answer (the model's prediction matched in stream_match.py, the state in state_check.py, the
two sides compared in differential.py). **Adding an oracle is one new module in this folder** that
calls :func:`register` with an :class:`Oracle` whose ``check`` judges every answer a side gives (see
tests/fuzz/test_added_oracle.py): :func:`oracles` imports every module of the folder, so nothing else
names it.

A failed check raises the oracle's own :class:`Finding` subclass, so the fuzzer confirms and
shrinks each kind of failure separately (fuzz/findings/confirm.py, fuzz/findings/shrink.py: by
replaying smaller scripts) and keeps one finding per oracle.
"""
from __future__ import annotations

import importlib
import pkgutil
import sys
from dataclasses import dataclass, field
from typing import Callable, Dict, Iterable, List, Mapping, NoReturn, Optional, Tuple, Type

__all__ = ["Oracle", "Answer", "Problem", "Finding", "register", "unregister", "oracles", "oracle_named",
           "oracle_names", "finding_class", "ALWAYS", "WITH_AGAINST", "WHERE_CHECKED"]

# When an oracle is a case of the JUnit file:
ALWAYS = "always"                 # in every campaign
WITH_AGAINST = "with --against"   # in differential mode only
WHERE_CHECKED = "where checked"   # where one of its checks ran, or it found something


@dataclass
class Problem:
    """What a check found wrong in one answer; the runner reports the first by its oracle's priority."""

    oracle: str       # the name of the oracle it belongs to
    message: str
    at: Optional[Tuple[int, int]] = None    # (expected item, received byte) where the answer went wrong


@dataclass(frozen=True)
class Answer:
    """What an added oracle's ``check`` judges: one side's answer to a step, or what it printed
    during a wait (the model's own oracles have judged it first)."""

    side: str         # the side's label (the target's, or --against's)
    release: str      # the release it is judged as (its profile's name)
    sent: bytes       # the step's input, fence included (b"" for a wait)
    received: bytes   # every byte the side printed for it


class Finding(AssertionError):
    """A failed oracle. ``traces`` holds what crossed each link in the failing run."""

    oracle = "finding"

    def __init__(self, message: str, traces: Optional[list] = None, details: Optional[dict] = None):
        super().__init__(f"[{self.oracle}] {message}")
        self.message = message
        self.traces = traces or []
        self.details = details or {}

    def __reduce__(self) -> tuple:
        # A --jobs worker sends its findings through a pipe: rebuilt from the registry by name, so an
        # added oracle's class needs no module attribute of its own.
        return _rebuilt, (self.oracle, self.message, self.traces, self.details)


def _rebuilt(oracle_name: str, message: str, traces: list, details: dict) -> Finding:
    return finding_class(oracle_name)(message, traces, details)


@dataclass(frozen=True)
class Oracle:
    """One oracle. ``priority``: of the problems found in one answer, the one of the lowest number is
    reported. ``case``: when the JUnit file has a case for it (``ALWAYS``, ``WITH_AGAINST``,
    ``WHERE_CHECKED``). ``per_answer``: judged on every answer a side gives (a step's, a wait's),
    counted once each; ``check`` (an added oracle's) is then called with that :class:`Answer` and
    returns the problems it found. ``target_lost``: a failure of it means the target may no longer
    answer, so the next run starts it again."""

    name: str
    help: str
    priority: int
    case: str = ALWAYS
    per_answer: bool = False
    target_lost: bool = False
    check: Optional[Callable[[Answer], Iterable[Problem]]] = None
    finding: Type[Finding] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.case not in (ALWAYS, WITH_AGAINST, WHERE_CHECKED):
            raise ValueError(f"oracle {self.name!r}: case {self.case!r} is not one of "
                             f"{ALWAYS!r}, {WITH_AGAINST!r}, {WHERE_CHECKED!r}")
        if self.check is not None and not self.per_answer:
            raise ValueError(f"oracle {self.name!r}: a check is called on every answer (per_answer=True)")
        named = {"oracle": self.name, "__module__": __name__}
        object.__setattr__(self, "finding", type(f"{self.name.capitalize()}Finding", (Finding,), named))

    def problem(self, message: str, at: Optional[Tuple[int, int]] = None) -> Problem:
        """A problem of this oracle in one answer."""
        return Problem(self.name, message, at)

    def fail(self, message: str, traces: List, details: Optional[dict] = None) -> NoReturn:
        raise self.finding(message, traces, details)

    def has_case(self, against: bool, checks: Mapping[str, int], found: bool) -> bool:
        """Whether the JUnit file of a campaign has a case for it (``against``: differential mode)."""
        if self.case == WITH_AGAINST:
            return against
        if self.case == WHERE_CHECKED:
            return bool(checks.get(self.name)) or found
        return True


_REGISTERED: Dict[str, Oracle] = {}
_PACKAGE = __name__.rpartition(".")[0]      # this folder's package (fuzz/oracles/)


def register(new: Oracle) -> Oracle:
    """Adds ``new`` to the registry (after the fuzzer's own and those registered before it: the
    JUnit file's order)."""
    importlib.import_module(f"{_PACKAGE}.built_in")      # (while it registers them: itself, as is)
    known = _REGISTERED.get(new.name)
    if known is not None and known != new:
        raise ValueError(f"an oracle named {new.name!r} is registered already")
    _REGISTERED[new.name] = new
    return new


def unregister(name: str) -> None:
    """Takes the oracle ``name`` out again (a test's planted oracle)."""
    _REGISTERED.pop(name, None)


def _import_folder() -> None:
    """Imports every module of this folder not imported yet: a module declaring an oracle registers it."""
    package = sys.modules[_PACKAGE]
    for module in sorted(m.name for m in pkgutil.iter_modules(package.__path__)):
        if f"{_PACKAGE}.{module}" not in sys.modules:
            importlib.import_module(f"{_PACKAGE}.{module}")


def oracles() -> Tuple[Oracle, ...]:
    """Every oracle, in the JUnit file's order: the fuzzer's own, then those added."""
    _import_folder()
    return tuple(_REGISTERED.values())


def oracle_names() -> Tuple[str, ...]:
    return tuple(o.name for o in oracles())


def oracle_named(name: str) -> Oracle:
    found = _REGISTERED.get(name)
    if found is None:
        _import_folder()
        found = _REGISTERED.get(name)
    if found is None:
        raise ValueError(f"unknown oracle {name!r} (known: {', '.join(oracle_names())})")
    return found


def finding_class(oracle_name: str) -> Type[Finding]:
    return oracle_named(oracle_name).finding
