"""A stream's line among the fence's own bytes: with echo on, a PID line (``debug 16``, every
10 ms) may come between the echoed ``version`` of the fence and the CRLF its CR gives. The reply
to the line before the fence is still exactly that line's output (the stream's line set aside),
never the fence's echo: the real firmware's code did this in the abbreviation probe of ``port``
(`p 2` seen as ``p 2\\r\\nP2>version``, a false failure)."""
from __future__ import annotations

from stream_injection import PID_LINE, echoing_hat  # noqa: E402

from buildhat_conformance.conformance.reply import without_fence_line


def test_the_fence_line_is_cut_around_a_stream_line() -> None:
    # after the echo, before the CRLF (as the real firmware's code printed it)
    assert without_fence_line(b"p 2\r\nP2>version" + PID_LINE + b"\r\n") == b"p 2\r\nP2>" + PID_LINE
    # between the CRLF and the answer
    assert without_fence_line(b"p 2\r\nP2>version\r\n" + PID_LINE) == b"p 2\r\nP2>" + PID_LINE
    # inside the echo
    assert without_fence_line(b"\r\nP0>ver" + PID_LINE + b"sion\r\n") == b"\r\nP0>" + PID_LINE
    # echo off: only the CRLF is the fence's; the command's own CRLF and output stay
    assert without_fence_line(b"\r\n" + PID_LINE + b"7.20 V\r\n\r\n") == b"\r\n" + PID_LINE + b"7.20 V\r\n"
    assert without_fence_line(b"\r\nError\r\n\r\n") == b"\r\nError\r\n"
    # nothing of the fence's: nothing cut
    assert without_fence_line(b"") == b""
    assert without_fence_line(PID_LINE) == PID_LINE


def test_a_stream_line_after_the_fence_echo_is_not_taken_for_the_reply() -> None:
    with echoing_hat(b'>version') as (hat, target):
        reply = hat.exchange("port 2")
        assert target.injected >= 2, "no PID line was put after the fence's echo"
        assert PID_LINE in reply.wire, reply.wire
        assert reply.raw == b"port 2\r\nP2>", reply.raw
        assert reply.errors == 0
        hat.exchange("echo 0 ; port 0")
