"""Transcript writer/reader and scenario-script parser against the shared formats."""
import io

import pytest

from buildhat_conformance.harness.transcript import TranscriptWriter, read_transcript
from buildhat_conformance.transcripts.script import ScriptError, format_action, parse_script, unescape_raw


def test_transcript_round_trips_exact_bytes():
    stream = b"\r\nType help <RETURN> for help\r\nP0>\xe2\x80\x93\xff\r\n\x00x"
    buf = io.StringIO()
    w = TranscriptWriter(buf, {"firmware": "1737564117"})
    for i in range(0, len(stream), 3):  # arbitrary chunking
        w.hat(i, stream[i:i + 3])
    w.host(50, b"vin\r\xfe")
    w.end(70)
    t = read_transcript(io.StringIO(buf.getvalue()))
    assert t.hat_bytes == stream
    assert t.host_bytes == b"vin\r\xfe"
    assert t.events[-1]["dir"] == "end"
    assert not any("partial" in e and e["partial"].startswith("P0>") for e in t.events)  # ended by CRLF
    assert "P0>\u2013\u00ff" in t.hat_lines()


def test_partial_is_written_when_host_sends():
    buf = io.StringIO()
    w = TranscriptWriter(buf, {"firmware": "x"})
    w.hat(1, b"\r\nP0>")
    w.host(2, b"v")
    evs = read_transcript(io.StringIO(buf.getvalue())).events
    assert [e.get("line", e.get("partial", e.get("bytes"))) for e in evs] == ["", "P0>", "v"]
    assert "partial" in evs[1]


def test_truncated_transcript_keeps_everything_before_the_crash():
    buf = io.StringIO()
    w = TranscriptWriter(buf, {"firmware": "x"})
    w.hat(1, b"a\r\nb\r\n")
    text = buf.getvalue() + '{"t":3,"dir":"hat","li'
    assert read_transcript(io.StringIO(text)).hat_lines() == ["a", "b"]


def test_script_parses_every_action():
    s = parse_script("""@name demo
;; comment
@device 3 0x3E
> port 0 ; vin
>raw v\\x69n\\r\\n
>
@wait 250
@plug 1 passive 5
@unplug 1
@data 0 1 05 00
@data 0 1 auto
@motorfault 1 2 01 02 03
@motorfault 0
@portfault 1
@button 1 1
@adc 4095
@rate 0 25
@hold 0 1
@pos 0 -90
""")
    assert s.name == "demo" and s.devices[3] == ("active", 0x3E) and s.devices[0] == ("active", 0x30)
    kinds = [a.kind for a in s.actions]
    assert kinds[:4] == ["send", "send", "send", "wait"]
    assert s.actions[0].data == b"port 0 ; vin\r"
    assert s.actions[1].data == b"vin\r\n"
    assert s.actions[2].data == b"\r"
    assert s.actions[8].args == (1, 2, b"\x01\x02\x03")
    assert s.actions[9].args == (0, None, None)
    assert {"plug", "unplug", "data", "motorfault", "portfault", "button", "adc", "rate", "hold",
            "pos"} <= s.capabilities
    assert s.duration_ms == 270


@pytest.mark.parametrize("bad", ["@plug 4 0x30", "@wait x", "@device 0 0x99", "vin", ">vin",
                                 ">raw \\q", "@adc 5000", "@frobnicate"])
def test_script_errors_name_the_line(bad):
    with pytest.raises(ScriptError, match=":2:"):
        parse_script("@name x\n" + bad)


def test_device_after_actions_is_an_error():
    with pytest.raises(ScriptError, match="before other actions"):
        parse_script("> vin\n@device 0 none")


def test_format_action_round_trip():
    s = parse_script("> vin\n>raw a\\sb\\x00\n>\n@wait 5\n@plug 2 0x3D\n")
    again = parse_script("\n".join(format_action(a) for a in s.actions))
    assert [(a.kind, a.args, a.data) for a in again.actions] == [(a.kind, a.args, a.data) for a in s.actions]


def test_raw_escapes():
    assert unescape_raw("\\r\\n\\t\\b\\\\\\s\\x7f") == b"\r\n\t\b\\ \x7f"


def test_partial_keeps_its_arrival_time():
    buf = io.StringIO()
    w = TranscriptWriter(buf, {"firmware": "x"})
    w.hat(5, b"\r\nP0>")
    w.host(40, b"vin\r")
    evs = read_transcript(io.StringIO(buf.getvalue())).events
    assert [(e["t"], e["dir"]) for e in evs] == [(5, "hat"), (5, "hat"), (40, "host")]


def test_a_port_fault_pulse_is_its_own_capability():
    s = parse_script("@portfault 1 11\n@portfault 1\n@portfault 0")
    assert [a.args for a in s.actions] == [(1, 11), (1,), (0,)]
    assert [a.capability for a in s.actions] == ["faultpulse", "portfault", "portfault"]
    for bad in ("@portfault 0 11", "@portfault 1 0", "@portfault 1 x"):
        with pytest.raises(ScriptError, match=":1:"):
            parse_script(bad)
