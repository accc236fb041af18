"""An echo torn by a line the HAT prints on its own (FIRMWARE-BEHAVIOUR.md#fb-echo, #fb-debug).

With echo on, the HAT echoes the host's bytes as they arrive, and a stream left on (``debug 16``
PID lines every 10 ms, data reports) prints whole lines between any two of them. The real
firmware's code did it in the abbreviation probes: ``ech`` + a PID line + ``o 0 ; port 0``. The
echo is recognised around that line, so the counted fence stays in step: no target fault
("garbled") for a healthy HAT."""
from __future__ import annotations

from stream_injection import PID_LINE, echoing_hat  # noqa: E402

from buildhat_conformance.harness.line_splitter import LineSplitter

REPORT = b"P0M3: +98\r\n"


def _events(sent: bytes, received: bytes) -> list:
    splitter = LineSplitter()
    splitter.host_sent(sent)
    return [(e.kind, e.text, e.fields.get("host_line")) for e in splitter.feed(received, 0.0)]


def test_an_echo_torn_by_a_pid_line_is_still_the_echo_of_its_host_line() -> None:
    got = _events(b"echo 0 ; port 0\rversion\r",
                  b"ech" + PID_LINE + b"o 0 ; port 0\r\n\r\nFirmware version: 1\r\n")
    assert got[0][0] == "pid_debug"
    assert got[1:] == [("echo", "echo 0 ; port 0", 1), ("blank", "", 2),
                       ("version", "Firmware version: 1", None)]


def test_an_echo_torn_twice_and_at_its_end() -> None:
    got = _events(b"port 0 ; select 3\r",
                  b"po" + REPORT + b"rt 0 ; sel" + PID_LINE + b"ect 3" + REPORT + b"\r\n")
    assert [k for k, _t, _n in got] == ["mode_data", "pid_debug", "mode_data", "echo"]
    assert got[-1] == ("echo", "port 0 ; select 3", 1)


def test_a_line_that_only_looks_like_a_torn_echo_is_left_alone() -> None:
    # not an unasked line after the echo's start: an answer of its own, and the echo still owed
    got = _events(b"vin\r", b"vi7.20 V\r\n")
    assert got == [("unknown", "vi7.20 V", None)]
    # a HAT that lost its line ending: the echo never completes, so nothing is counted as it
    got = _events(b"vin\rversion\r", b"vin" + b"version\r\n")
    assert all(n is None for _k, _t, n in got)


def test_the_counted_fence_finds_its_answer_after_a_torn_echo() -> None:
    with echoing_hat(b'P0>ech') as (hat, target):
        reply = hat.exchange("echo 0 ; port 0")      # raised TargetFault (garbled) before
        assert target.injected == 1, "no PID line was put inside the echo"
        assert reply.raw == b"echo 0 ; port 0\r\n", reply.raw
        assert PID_LINE in reply.wire
        assert hat.exchange("vin").raw.endswith(b" V\r\n")
