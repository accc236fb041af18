"""A HAT whose reset lands in the middle of a line: a pytest plugin adding the target
``tornreset:<how>`` (the in-process R7 emulator, in virtual time) for a child pytest of the suite.

- ``torn``: the reset cuts a ``deltat=`` line the HAT was sending; its first bytes (``deltat=00000``)
  reach the host, and the start-up's CRLF ends them (what a paced target, ``sil:TREE?speed=1``, shows
  when a ``@reset`` lands while that line crosses the wire; in virtual time it is made exact here).
- ``no-empty-line``: a wrong HAT whose start-up lacks its first line, the empty one.

Loaded with ``-p torn_reset_target`` and this folder on PYTHONPATH
(tests/end_to_end/test_conformance_torn_reset.py).
"""
from __future__ import annotations

import functools
from typing import Any, Callable

from buildhat_conformance.emulator import Emulator
from buildhat_conformance.emulator.targets.in_process import InProcessTarget
from buildhat_conformance.emulator.targets.in_process import from_url as inprocess_from_url
from buildhat_conformance.harness.targets import TargetError, register

HOW = ("torn", "no-empty-line")
LEFTOVER = b"deltat=00000"        # the first bytes of `deltat=00000003`


class ResetMidLine:
    """An :class:`Emulator` whose output right after a ``@reset`` is changed as ``how`` says."""

    def __init__(self, how: str, **kwargs: Any):
        self.emu = Emulator(**kwargs)
        self.how = how
        self._head = b""              # bytes to put before the output after the reset
        self._strip = False           # drop the start-up's first CRLF

    def world(self, line: str) -> str:
        reply = self.emu.world(line)
        if line.split()[:1] == ["@reset"]:
            if self.how == "torn":
                self._head = LEFTOVER
            else:
                self._strip = True
        return reply

    def read(self) -> bytes:
        out = self.emu.read()
        if self._head:
            out, self._head = self._head + out, b""
        if self._strip and b"\r\n" in out:
            self._strip = False
            out = out.replace(b"\r\n", b"", 1)
        return out

    def __getattr__(self, name: str) -> Any:
        # now, boot, step, advance, advance_until_output, on_event ...: the emulator's (not while
        # copying, when 'emu' does not exist yet).
        if name.startswith("__") or name == "emu":
            raise AttributeError(name)
        return getattr(self.emu, name)


def from_url(url: str, **options: Any) -> InProcessTarget:
    how = url.split(":", 1)[1] if ":" in url else ""
    if how not in HOW:
        raise TargetError(f"tornreset: unknown variant {how!r}; known: {', '.join(HOW)}")
    return inprocess_from_url("inprocess:R7", factory=_factory(how), **options)


@functools.cache
def _factory(how: str) -> Callable[..., ResetMidLine]:
    return functools.partial(ResetMidLine, how)


register("tornreset", from_url)
