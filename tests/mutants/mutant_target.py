"""The mutant HAT in virtual time: a pytest plugin adding the target ``mutant:<MUTATION>[:<release>]``.

Loaded into a child pytest of the conformance suite with ``-p mutant_target`` (this folder on
PYTHONPATH, as tests/mutants/suite_run.py does). The target is the ``inprocess`` one
(emulator/targets/in_process.py) whose emulator is wrapped by :class:`MutantHat`: the same named
mutations as the pty relay (mutant_emulator.py, line_mutations.py) on the same boundary, output
lines and host bytes, so the suite runs in HAT time instead of waiting on the wall clock.
"""
from __future__ import annotations

import functools
from typing import Any, Callable

from line_mutations import MUTATIONS, Mutation

from buildhat_conformance.emulator import Emulator
from buildhat_conformance.emulator.targets.in_process import InProcessTarget
from buildhat_conformance.emulator.targets.in_process import from_url as inprocess_from_url
from buildhat_conformance.harness.targets import TargetError, register

# The relay passes a partial line (a prompt) on after 10 ms without more output; so does this, in HAT ms.
PARTIAL_AFTER_MS = 10


class MutantHat:
    """An :class:`Emulator` whose output lines and host bytes go through one :class:`Mutation`."""

    def __init__(self, mutation: str, **kwargs: Any):
        self.emu = Emulator(**kwargs)
        self.mutation = Mutation(mutation, kwargs.get("firmware"))
        self._out = bytearray()          # mutated, for the host
        self._partial = bytearray()      # output after the last CRLF
        self._partial_since = 0

    def write(self, data: bytes) -> None:
        self.emu.write(self.mutation.host(bytes(data)))

    def _pull(self) -> None:
        raw = self.emu.read()
        if raw:
            if not self._partial:
                self._partial_since = self.emu.now
            self._partial += raw
            while b"\r\n" in self._partial:
                line, _, rest = bytes(self._partial).partition(b"\r\n")
                self._partial = bytearray(rest)
                new = self.mutation.line(line)
                if new is not None:
                    self._out += new + b"\r\n"
        if self._partial and self.emu.now - self._partial_since >= PARTIAL_AFTER_MS:
            self._out += self._partial
            self._partial.clear()

    def read(self) -> bytes:
        self._pull()
        out = bytes(self._out)
        self._out.clear()
        return out

    def advance_until_output(self, ms: int) -> int:
        """As :meth:`Emulator.advance_until_output`, for the mutated output (a dropped line is no output)."""
        start = self.emu.now
        while True:
            self._pull()
            left = ms - (self.emu.now - start)
            if self._out or left <= 0:
                return self.emu.now - start
            if self._partial:      # wait for the rest of the line, or until it goes out as it is
                self.emu.advance(min(left, max(1, self._partial_since + PARTIAL_AFTER_MS - self.emu.now)))
            else:
                self.emu.advance_until_output(left)

    def __getattr__(self, name: str) -> Any:
        # now, boot, step, advance, world, hat, on_event ...: the real emulator's (not while copying,
        # when 'emu' does not exist yet).
        if name.startswith("__") or name == "emu":
            raise AttributeError(name)
        return getattr(self.emu, name)


def from_url(url: str, **options: Any) -> InProcessTarget:
    """``mutant:<MUTATION>[:<release>][?inprocess options]``."""
    rest = url.split(":", 1)[1] if ":" in url else ""
    mutation, _, release = rest.partition(":")
    mutation, _, query = mutation.partition("?")
    if mutation not in MUTATIONS:
        raise TargetError(f"mutant: unknown mutation {mutation!r}; known: {', '.join(MUTATIONS)}")
    inner = "inprocess" + (":" + release if release else "") + ("?" + query if query else "")
    return inprocess_from_url(inner, factory=_factory(mutation), **options)


@functools.cache
def _factory(mutation: str) -> Callable[..., MutantHat]:
    # One factory per mutation: the in-process target keeps a booted HAT per factory and copies it.
    return functools.partial(MutantHat, mutation)


register("mutant", from_url)
