"""The emulator as a process: pty (with pyserial), TCP, control channel, script mode, the pytest fixture.

Real child processes, a real pty and real sockets. Waits are generous deadlines, never timing assertions.
"""
from __future__ import annotations

import io
import json
import os
import socket
import subprocess
import sys
import time

import pytest
import serial

from buildhat_conformance.emulator.cli import main
from buildhat_conformance.emulator.host_fixtures.pytest_plugin import EmulatorProcess

CLI = [sys.executable, "-m", "buildhat_conformance.emulator.cli"]
VERSION_R7 = b"Firmware version: 1737564117 2025-01-22T16:41:57+00:00\r\n"
EMPTY_ARGS = ["--device", "0=none", "--device", "1=none", "--device", "2=none"]


def read_until(ser: serial.Serial, marker: bytes, timeout: float = 10.0) -> bytes:
    data = b""
    deadline = time.monotonic() + timeout
    while marker not in data and time.monotonic() < deadline:
        data += ser.read(ser.in_waiting or 1)
    return data


def test_pty_with_pyserial_version_and_control(tmp_path):
    with EmulatorProcess(firmware="R7", devices={0: None, 1: None, 2: None}, speed=5,
                         args=["--link", str(tmp_path / "hat")]) as emu:
        emu.wait_settled()
        assert os.path.realpath(tmp_path / "hat") == os.path.realpath(emu.path)
        assert emu.firmware == "1737564117 2025-01-22T16:41:57+00:00"
        ser = serial.Serial(str(tmp_path / "hat"), 115200, timeout=0.2)
        try:
            ser.write(b"version\r")
            out = read_until(ser, VERSION_R7)
            assert out.endswith(b"\r\n" + VERSION_R7)       # raw mode: CRLF exactly, no translation
            assert emu.control("@adc 2000") == "ok"
            # The firmware samples the ADC once per 1 ms tick (docs/FIRMWARE-BEHAVIOUR.md#fb-timing):
            # a `vin` handled in the same millisecond as the action may still show the old value.
            time.sleep(0.05)
            ser.write(b"vin\r")
            assert read_until(ser, b" V\r\n").endswith(b"\r\n9.18 V\r\n")   # §4.4 with ADC 2000
            assert emu.control("@nonsense").startswith("error ")
            assert emu.control("@time").startswith("ok ")
            assert emu.control("@speed") == "ok 5"
            # a byte with the top bit set and a lone LF travel unchanged (8-bit clean, no icrnl/onlcr)
            ser.write(b"echo 1\r\xe9\n\r")
            assert read_until(ser, b"Error\r\nP0>").endswith(b"\r\nP0>\xe9\n\r\nError\r\nP0>")
        finally:
            ser.close()
    assert not os.path.lexists(tmp_path / "hat")            # the symlink is removed on exit


def test_tcp_mode_and_unix_control(tmp_path):
    ctl = str(tmp_path / "c.sock")
    proc = subprocess.Popen(CLI + ["--tcp", "127.0.0.1:0", "--control", ctl, "--speed", "10"] + EMPTY_ARGS,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        host, port = proc.stdout.readline().decode().strip().rsplit(":", 1)
        conn = socket.create_connection((host, int(port)), timeout=10)
        deadline = time.monotonic() + 10
        while not os.path.exists(ctl) and time.monotonic() < deadline:
            time.sleep(0.02)
        c = socket.socket(socket.AF_UNIX)
        c.connect(ctl)
        f = c.makefile("rw")
        while True:                                           # until `Done initialising ports`
            f.write("@settled\n")
            f.flush()
            if f.readline().strip() == "ok 1" or time.monotonic() > deadline:
                break
            time.sleep(0.02)
        conn.sendall(b"version\r")
        data = b""
        while VERSION_R7 not in data and time.monotonic() < deadline:
            data += conn.recv(4096)
        assert data.endswith(b"\r\n" + VERSION_R7)
        c.close()
        conn.close()
    finally:
        proc.terminate()
        proc.wait(10)
    assert not os.path.exists(ctl)


SCRIPT = """\
@name determinism
> version
@wait 25
> echo 1
>raw port 1\\r\\nlist\\r
@adc 2000
> vin
@wait 120
"""


def test_script_mode_is_deterministic_and_well_formed(tmp_path):
    path = tmp_path / "s.script"
    path.write_text(SCRIPT)
    runs = [subprocess.run(CLI + ["--script", str(path)], capture_output=True, timeout=60) for _ in range(2)]
    assert runs[0].returncode == 0, runs[0].stderr
    assert runs[0].stdout == runs[1].stdout
    events = [json.loads(line) for line in runs[0].stdout.decode().splitlines()]
    meta = events[0]
    assert meta["dir"] == "meta" and meta["firmware"].startswith("1737564117")
    assert meta["devices"] == {"0": "0x30", "1": "0x40", "2": "passive 8", "3": "none"}
    assert events[-1]["dir"] == "end"
    times = [e["t"] for e in events[1:]]
    assert times == sorted(times)                              # in time order
    assert min(times) == -meta["prelude_ms"]                   # start-up at t < 0
    lines = [e["line"] for e in events if e.get("dir") == "hat" and "line" in e]
    assert "Done initialising ports" in lines
    # every device of the default layout is up before t = 0
    early = [e["line"] for e in events if e.get("dir") == "hat" and "line" in e and e["t"] < 0]
    assert "P0: established serial communication with active ID 30" in early
    assert "P1: established serial communication with active ID 40" in early
    assert "P2: connected to passive ID 8" in early
    host = [e for e in events if e.get("dir") == "host"]
    assert host[0] == {"t": 0, "dir": "host", "bytes": "version\r"}
    assert events[-1]["t"] == 25 + 120 + 20                    # 20 ms tail after the last action


def test_script_with_unknown_world_action_fails_clearly(tmp_path):
    path = tmp_path / "bad.script"
    path.write_text("> version\n@frobnicate 1\n")
    run = subprocess.run(CLI + ["--script", str(path)], capture_output=True, timeout=60)
    assert run.returncode == 2 and b"bad.script:2" in run.stderr


@pytest.mark.parametrize("args,needle", [
    (["--firmware", "R9", "--stdio"], "unknown firmware"),
    (["--device", "7=0x30", "--stdio"], "--device"),
    (["--device", "0=0x99", "--stdio"], "0x99"),
    (["--speed", "0", "--stdio"], "--speed"),
    (["--link", "/tmp/x", "--stdio"], "--link needs --pty"),
    ([], "one of the arguments"),
    (["--tcp", "notaport"], "--tcp"),
    (["--script", "/nonexistent/x.script"], "cannot read"),
    (["--booted", "--bootloader", "--stdio"], "--booted"),
    (["--booted", "--script", "x.script"], "--booted"),
])
def test_bad_flags_give_clear_errors(args, needle, capsys):
    try:
        status = main(args)
    except SystemExit as exc:            # argparse's own usage errors
        status = exc.code
    assert status == 2
    assert needle in capsys.readouterr().err


def test_help_documents_the_control_protocol():
    run = subprocess.run(CLI + ["--help"], capture_output=True, timeout=60)
    assert run.returncode == 0
    for word in (b"@plug", b"@reset bootloader", b"@time", b"@lint", b"--control"):
        assert word in run.stdout


def test_stdio_mode_answers_and_exits_on_eof():
    proc = subprocess.Popen(CLI + ["--stdio", "--speed", "20"] + EMPTY_ARGS, stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    stdout = proc.stdout
    assert isinstance(stdout, io.BufferedReader)      # read1: what has come, without waiting for more
    try:
        out = b""
        while b"Done initialising ports\r\n" not in out:
            chunk = stdout.read1(4096)
            assert chunk, proc.stderr.read()
            out += chunk
        proc.stdin.write(b"version\r")
        proc.stdin.flush()
        while VERSION_R7 not in out:
            chunk = stdout.read1(4096)
            assert chunk, proc.stderr.read()
            out += chunk
        assert out.endswith(b"Done initialising ports\r\n\r\n" + VERSION_R7)
        proc.stdin.close()
        assert proc.wait(20) == 0                      # EOF on stdin ends the run
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.mark.buildhat_emulator(firmware="R5", devices={0: None, 1: None, 2: None}, speed=10)
def test_pytest_fixture(buildhat_emulator):
    assert buildhat_emulator.firmware.startswith("1670596313")
    with serial.Serial(buildhat_emulator.path, 115200, timeout=0.2) as ser:
        ser.write(b"version\r")
        assert read_until(ser, b"+00:00\r\n").endswith(
            b"\r\nFirmware version: 1670596313 2022-12-09T14:31:53+00:00\r\n")


def test_bad_key_and_bad_link_give_clear_errors(tmp_path, capsys):
    bad = tmp_path / "bad.pem"
    bad.write_text("not a key\n")
    assert main(["--pty", "--bootloader", "--bootloader-key", str(bad)]) == 2
    assert "not a PEM public key" in capsys.readouterr().err
    assert main(["--pty", "--link", str(tmp_path / "no" / "such" / "dir")]) == 2
    assert "--link" in capsys.readouterr().err
    regular = tmp_path / "file"
    regular.write_text("x")
    assert main(["--pty", "--link", str(regular)]) == 2
    assert "not a symlink" in capsys.readouterr().err and regular.read_text() == "x"


def test_pty_paces_a_hats_wire_unless_told_otherwise():
    # Issue 37: `--pty` (and `--tcp`) as it comes is a HAT's 115200-baud wire both ways; `--baud 0` an
    # unpaced link; --help says so. `help` (about 4.2 KB) takes at least 0.36 s of such a wire: the bound
    # is a floor, which a loaded machine only makes easier to meet; the unpaced link is far under it.
    from buildhat_conformance.emulator.cli import build_parser, link_baud
    parser = build_parser()
    text = parser.format_help()
    assert "default 115200 with --pty and --tcp" in " ".join(text.split())
    assert "0: an unpaced link" in " ".join(text.split())
    assert link_baud(parser.parse_args(["--pty"])) == 115200
    assert link_baud(parser.parse_args(["--tcp", "0"])) == 115200
    assert link_baud(parser.parse_args(["--pty", "--baud", "0"])) is None
    assert link_baud(parser.parse_args(["--stdio"])) is None
    took = {}
    for name, args in (("wire", []), ("unpaced", ["--baud", "0"])):
        with EmulatorProcess(firmware="R7", devices={0: None, 1: None, 2: None},
                             args=["--booted"] + args) as emu:
            ser = serial.Serial(emu.path, 115200, timeout=0.2)
            try:
                t0 = time.monotonic()
                ser.write(b"help\r")
                out = read_until(ser, b"8=DATA payload")
                took[name] = time.monotonic() - t0
                assert len(out) > 4000
            finally:
                ser.close()
    assert took["wire"] >= 0.36, took
