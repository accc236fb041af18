"""Issue 24: output still draining from a stream is waited out or set aside before a case's set-up
is judged, and output cut by a full TX ring (FIRMWARE-FACTS §1, §7.4) is the HAT's own output,
not "bytes no Build HAT prints". In virtual time, on the in-process emulator."""
from __future__ import annotations

import re
from typing import Any

from buildhat_conformance.conformance.hat_under_test import HatUnderTest
from buildhat_conformance.conformance.target_fault import foreign
from buildhat_conformance.conformance.tee import VirtualTeeTarget
from buildhat_conformance.harness.events import classify
from buildhat_conformance.harness.session import Session
from buildhat_conformance.harness.targets import make_target

PID_LINE = b"P0: pv=0.000000 sp=0.000000: e=0.000000 ie=0.000000 de=0.000000 cv=0.000000\r\n"
FOUR_MOTORS = "&".join(f"device={p}=0x30" for p in range(4))


class PidLineAfterSyncEcho(VirtualTeeTarget):
    """The HAT as the real firmware's code was seen: a PID line still draining comes between the
    echo of the sync's line and its `version` answer."""

    injected = 0

    def read(self, timeout: float) -> bytes:
        data = super().read(timeout)
        data, n = re.subn(rb"(\x00sync-[0-9a-f]+-[0-9]+\r\n)", lambda m: m.group(1) + PID_LINE, data)
        self.injected += n
        return data


def _session(url: str, target: Any = None) -> Session:
    s = Session(target or make_target(url))
    s.open()
    return s


def test_a_stream_line_between_the_sync_echo_and_its_answer_is_set_aside() -> None:
    target = PidLineAfterSyncEcho(make_target("inprocess:R7"))
    s = _session("", target)
    try:
        result = s.sync(1.0, attempts=1)
        assert target.injected == 1, "the PID line was not put between echo and answer"
        assert s.events[result.answer].kind == "version"
        assert s.events[result.answer - 1].kind == "pid_debug"
    finally:
        s.close()


def test_output_cut_by_a_full_tx_ring_is_not_foreign() -> None:
    def event(text: str) -> Any:
        return classify(text.encode(), 0.0)

    cut = event("P0: pv=12 sp=0.00P1: pv=3 sp=0.000000: e=0.000000 ie=0.0")
    assert cut.kind == "unknown" and not foreign(cut)
    assert foreign(event("FLOOD 000001 the quick brown fox jumps over the lazy dog"))
    assert not foreign(event("P0: pv=1.000000 sp=0.000000: e=0.000000 ie=0.000000 de=0.000000 cv=0.000000"))


def test_set_up_after_streams_that_overflow_the_wire_finds_its_place() -> None:
    # Four ports in PID mode with debug 16 and reports every tick overflow 115200 baud, so the
    # paced emulator's TX ring fills and drops output (FACTS §1). The next set-up must stop the
    # streams, wait them out and find its place: no target fault, and the link in step after.
    url = f"inprocess:R7?baud=115200&{FOUR_MOTORS}"
    s = _session(url)
    hat = HatUnderTest(s, s.target, url)
    try:
        hat.resync()
        hat.clauses.held("echo")
        hat.clauses.held("separator")
        for rnd in range(2):
            for p in range(4):
                pid = hat.pid_command(p, 3, 0, "s2", "0", "0", "0", "0", "0", "0", "0")
                hat.setup(f"port {p} ; select 3 ; {pid} ; set 0 ; debug 16 ; selrate 1")
            s.sleep(hat.seconds(500))
            assert s.target.emulator.hat.tx_pending() > 4096, "the streams did not fill the TX ring"
            hat.resync()
            assert hat.exchange("vin").raw.endswith(b" V\r\n"), rnd
    finally:
        s.close()


def test_a_world_action_the_target_cannot_perform_for_this_device_skips_the_case() -> None:
    """A target that plugs some devices and not others (rp2040: plugs passive devices only) raises
    NeedsCapability for the others: the case skips saying so; it is neither a failure nor a fault."""
    import pytest

    from buildhat_conformance.harness.targets.base import NeedsCapability

    class PassiveOnly:
        def world(self, line: str) -> str:
            raise NeedsCapability("an active device", "test:", "passive devices only")

    hat = HatUnderTest.__new__(HatUnderTest)
    hat.session, hat.url = PassiveOnly(), "test:"
    with pytest.raises(pytest.skip.Exception, match="needs an active device"):
        hat.world("@plug 0 0x30")
