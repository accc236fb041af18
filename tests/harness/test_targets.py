"""Targets and their error messages, each against the real thing: device paths (missing,
permission denied, busy, not a tty, the Pi 5 debug UART), ``cmd:`` child processes, the
``emulator`` target (a stand-in emulator process on a pty with a control socket), and the URL
registry."""
from __future__ import annotations

import os
import re
import shlex
import shutil
import sys
import tempfile

import pytest
from harness_fakehat import HERE as FAKEHAT  # noqa: E402
from harness_fakehat import PtyResponder
from target_kinds import make_target_of

from buildhat_conformance.emulator.targets.pty_process import EmulatorTarget
from buildhat_conformance.harness.errors import TargetError
from buildhat_conformance.harness.session import Session
from buildhat_conformance.harness.targets import make_target, open_target
from buildhat_conformance.harness.targets.serial_device import SerialTarget, pi5_debug_uart_remark

PY = shlex.quote(sys.executable)


# -- serial device paths ----------------------------------------------------------------------
def test_missing_device_lists_what_exists():
    with pytest.raises(TargetError) as info:
        open_target("/dev/ttyNOSUCH9")
    msg = str(info.value)
    assert "no such device: /dev/ttyNOSUCH9" in msg and "Serial ports on this machine" in msg


def test_missing_serial0_mentions_enable_uart():
    if os.path.exists("/dev/serial0"):
        pytest.skip("this machine has /dev/serial0")
    with pytest.raises(TargetError, match="enable_uart=1"):
        open_target("/dev/serial0")


def _open_as_nobody(path: str) -> str:
    """Open ``path`` as a serial target in a forked child that dropped root; returns the message."""
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the child reports through the pipe
        try:
            os.setgid(65534)
            os.setuid(65534)
            try:
                SerialTarget(path).open()
                msg = "opened"
            except TargetError as exc:
                msg = str(exc)
            os.write(w, msg.encode())
        finally:
            os._exit(0)
    os.close(w)
    chunks = []
    while True:
        chunk = os.read(r, 65536)
        if not chunk:
            break
        chunks.append(chunk)
    os.close(r)
    os.waitpid(pid, 0)
    return b"".join(chunks).decode()


def test_permission_denied_mentions_dialout():
    # A mode-000 file in a world-traversable directory. Root ignores file modes, so as root the
    # open runs in a forked child that has dropped to 'nobody' (the real EACCES path).
    tmp = tempfile.mkdtemp(prefix="bh-perm-", dir="/tmp")
    try:
        os.chmod(tmp, 0o755)
        dev = os.path.join(tmp, "ttyLOCKED")
        open(dev, "wb").close()
        os.chmod(dev, 0)
        if os.geteuid() == 0:
            msg = _open_as_nobody(dev)
        else:
            with pytest.raises(TargetError) as info:
                SerialTarget(dev).open()
            msg = str(info.value)
        assert "permission denied" in msg and "dialout" in msg and "sudo usermod -aG dialout $USER" in msg
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def test_busy_port_names_the_holder():
    responder = PtyResponder()
    first = SerialTarget(responder.path)
    try:
        first.open()
        with pytest.raises(TargetError) as info:
            SerialTarget(responder.path).open()
        msg = str(info.value)
        assert "is busy" in msg and "another process has it open" in msg
        assert f"{os.getpid()} (" in msg and "this process" in msg
    finally:
        first.close()
        responder.close()
    # once closed, it opens again
    responder = PtyResponder()
    try:
        t = SerialTarget(responder.path)
        t.open()
        t.close()
    finally:
        responder.close()


def test_busy_port_held_by_another_process():
    import subprocess
    responder = PtyResponder()
    holder = subprocess.Popen(
        [sys.executable, "-c", "import serial, sys, time; p = serial.Serial(sys.argv[1], exclusive=True); "
         "print('held', flush=True); time.sleep(60)", responder.path],
        stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(TargetError) as info:
            SerialTarget(responder.path).open()
        msg = str(info.value)
        assert "is busy" in msg and f"{holder.pid} (python" in msg
    finally:
        holder.kill()
        holder.wait()
        responder.close()


def test_a_directory_and_a_regular_file_are_not_serial_ports(tmp_path):
    with pytest.raises(TargetError, match="is a directory"):
        open_target(str(tmp_path))
    f = tmp_path / "plain"
    f.write_text("x")
    with pytest.raises(TargetError, match="not a serial port"):
        open_target(str(f))


def test_pi5_serial0_pointing_at_the_debug_uart(tmp_path):
    debug = tmp_path / "ttyAMA10"
    debug.write_text("")
    link = tmp_path / "serial0"
    link.symlink_to(debug)
    with pytest.raises(TargetError) as info:
        open_target(str(link))
    msg = str(info.value)
    assert "Raspberry Pi 5 debug UART" in msg and "/dev/ttyAMA0" in msg and "ttyAMA10" in msg
    assert pi5_debug_uart_remark(str(tmp_path / "plain")) is None


def test_serial_url_options():
    responder = PtyResponder()
    try:
        t = make_target(f"serial://{responder.path}?baud=115200")
        assert isinstance(t, SerialTarget) and t.baudrate == 115200 and t.path == responder.path
        with Session(t) as s:
            assert s.profile.name == "R7"
        with pytest.raises(TargetError, match="unknown option 'speed'"):
            make_target(f"serial://{responder.path}?speed=3")
        with pytest.raises(TargetError, match="baud must be a number"):
            make_target(f"serial://{responder.path}?baud=fast")
    finally:
        responder.close()


# -- cmd: --------------------------------------------------------------------------------------
def test_cmd_target_speaks_through_pipes():
    with Session(make_target(f"cmd:{PY} -u {FAKEHAT} --stdio")) as s:
        assert s.profile.name == "R7"
        assert [e.kind for e in s.command("vin")] == ["blank", "vin"]


def test_cmd_target_exit_reports_status_and_stderr():
    s = Session(make_target(f"cmd:{PY} -u {FAKEHAT} --stdio --die-after 2")).open()
    try:
        with pytest.raises(TargetError) as info:
            s.command("vin")
            s.command("vin")
        msg = str(info.value)
        assert "exited with status 3" in msg and "its last stderr lines" in msg
        assert re.search(r"fakehat: giving up after \d+ commands", msg)
    finally:
        s.close()


def test_cmd_target_not_found_and_bad_quoting():
    with pytest.raises(TargetError, match="command not found"):
        open_target("cmd:/no/such/program --x")
    with pytest.raises(TargetError, match="cannot split"):
        make_target("cmd:python3 'unterminated")


# -- emulator (a stand-in process: a pty, its path on stdout, a control socket) ----------------
def _standin(extra: str = "") -> str:
    return f"{PY} -u {FAKEHAT}" + (f" {extra}" if extra else "")


def test_emulator_target_runs_process_pty_and_control():
    target = make_target("emulator:R7?speed=4&device=2=passive+8&device=3=0x30", command=_standin())
    assert isinstance(target, EmulatorTarget)
    args = target.argv("/tmp/ctl")
    assert args[-11:] == ["--pty", "--control", "/tmp/ctl", "--firmware", "R7", "--speed", "4",
                          "--device", "2=passive 8", "--device", "3=0x30"]
    with Session(target) as s:
        assert target.pty_path is not None and os.path.exists(target.pty_path)
        assert s.time_scale == 4.0            # from the control channel's @speed
        assert s.profile.name == "R7"
        assert s.world("@plug 1 0x30") == ""
        assert s.expect("connecting", 5).port == 1
        assert target.control.request("@devices") == "2=passive 8;3=0x30"
        with pytest.raises(TargetError, match="emulator refused '@explode': no such action"):
            target.control.action("@explode")
        pid = target.child.pid
    assert target.child is None and pid is not None
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)


def test_emulator_failing_to_start_shows_its_own_error():
    target = make_target_of(EmulatorTarget, "emulator:R99",
                            command=_standin("--fail 'unknown firmware R99; known: R1..R7'"))
    with pytest.raises(TargetError) as info:
        target.open()
    msg = str(info.value)
    assert "the emulator failed to start" in msg and "exit status 2" in msg
    assert "unknown firmware R99; known: R1..R7" in msg
    assert target.child is None


def test_emulator_not_printing_a_path():
    target = make_target("emulator", command=[sys.executable, "-c", "print('hello'); import time"])
    with pytest.raises(TargetError, match="printed 'hello' where its pty path belongs"):
        target.open()


def test_emulator_url_errors():
    with pytest.raises(TargetError, match="device takes P=SPEC"):
        make_target("emulator?device=7=0x30")
    with pytest.raises(TargetError, match="passive device id"):
        make_target("emulator?device=1=passive+99")
    with pytest.raises(TargetError, match="speed must be positive"):
        make_target("emulator?speed=0")
    with pytest.raises(TargetError, match="unknown option 'colour'"):
        make_target("emulator:latest?colour=red")
    with pytest.raises(TargetError, match="did you mean emulator:R5"):
        make_target("emulatorR5")
    t = make_target_of(EmulatorTarget, "emulator:R5?device=1=0x30", devices={2: None})
    assert t.devices == {1: ("active", 0x30), 2: None} and t.firmware == "R5"


# -- registry ----------------------------------------------------------------------------------
def test_unknown_url_lists_the_known_forms():
    with pytest.raises(TargetError) as info:
        make_target("ftp://example")
    assert "unknown target 'ftp://example'" in str(info.value) and "cmd:<command line>" in str(info.value)
    with pytest.raises(TargetError, match="no target given"):
        make_target("  ")
