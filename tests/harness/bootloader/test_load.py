"""`buildhat-conformance load` (harness/bootloader/): the bootloader protocol of FIRMWARE-FACTS §9 against
the emulator's bootloader, on real processes (cmd: stdio, a pty), with every refusal as one line and an
exit status; the upload's pacing math; the progress display."""
from __future__ import annotations

import io
import pathlib
import shlex
import subprocess
import sys

import pytest
from firmware_images import files, image_of
from repo_paths import TESTS

from buildhat_conformance.bench import firmware_load as bench_load
from buildhat_conformance.bench.firmware_load import new_key, sign
from buildhat_conformance.cli import main as cli
from buildhat_conformance.harness.bootloader.client import BootloaderClient, wire_seconds
from buildhat_conformance.harness.bootloader.image import FirmwareImage
from buildhat_conformance.harness.bootloader.progress import Progress
from buildhat_conformance.harness.bootloader.wire import Wire
from buildhat_conformance.harness.targets.base import Target
from buildhat_conformance.protocol.profiles import get_profile

HERE = TESTS
BIN = pathlib.Path(sys.executable).parent
EMULATOR = str(BIN / "buildhat-emulator")
LINK = [sys.executable, str(HERE / "load_faulty_link.py")]


def load(capsys, target: str, img: str, sig: str, *extra: str):
    code = cli(["load", "--target", target, *extra, img, sig])
    out, err = capsys.readouterr()
    return code, out, err


def stdio(*args: str) -> str:
    return "cmd:" + shlex.join([EMULATOR, "--stdio", *args])


def error_lines(err: str) -> list:
    return [ln for ln in err.splitlines() if ln.startswith("buildhat-conformance load:")]


# -- the whole sequence ----------------------------------------------------------------------

def test_load_starts_the_release_the_image_is(capsys, tmp_path):
    img, sig = files(tmp_path, image_of("R3"))
    transcript = tmp_path / "load.jsonl"
    code, out, err = load(capsys, stdio("--bootloader"), img, sig, "--transcript", str(transcript))
    assert code == 0, err
    r3 = get_profile("R3")
    assert f"loaded: firmware version {r3.version_string}" in out
    assert bench_load._LOADED.search(out), out            # what `make bench` reads its figures from
    assert "bootloader version 1737564075" in out
    assert "Traceback" not in err
    # every byte both ways is in the transcript: the commands of §9 in order, the image whole
    text = transcript.read_text()
    for step in ("clear\\r", f"load 600 {r3.image_checksum}\\r", "signature 64\\r", "reboot\\r",
                 "Checksum OK", "Signature received", "Rebooting...", "Done initialising ports",
                 "Firmware version: " + r3.version_string):
        assert step in text, step


def test_running_firmware_without_a_reset_is_one_line_and_status_3(capsys, tmp_path):
    img, sig = files(tmp_path, image_of("R3"))
    code, _out, err = load(capsys, stdio(), img, sig)
    assert code == 3
    (line,) = error_lines(err)
    assert "runs firmware" in line and "?reset=gpio" in line and "power-cycle" in line


def test_running_firmware_is_reset_into_the_bootloader_through_the_emulator_control(capsys, tmp_path):
    img, sig = files(tmp_path, image_of("R5"))
    code, out, err = load(capsys, "emulator:R7?booted=1", img, sig)
    assert code == 0, err
    assert "resetting it into its bootloader" in out
    assert f"loaded: firmware version {get_profile('R5').version_string}" in out


# -- refusals: one line each, and the exit status --------------------------------------------

def test_checksum_failure_from_a_corrupting_link(capsys, tmp_path):
    img, sig = files(tmp_path, image_of("R7", 2000))
    code, _out, err = load(capsys, "cmd:" + shlex.join(LINK + ["--flip", "700"]), img, sig)
    assert code == 3
    (line,) = error_lines(err)
    assert "Checksum failure" in line and "link" in line
    assert "Traceback" not in err


def test_data_timeout_from_a_stalling_link(capsys, tmp_path):
    img, sig = files(tmp_path, image_of("R7", 2000))
    code, _out, err = load(capsys, "cmd:" + shlex.join(LINK + ["--stop", "900"]), img, sig)
    assert code == 3
    (line,) = error_lines(err)
    assert "Timed out waiting for data" in line


def test_image_too_large_is_refused_before_any_data(capsys, tmp_path):
    img, sig = files(tmp_path, bytes(245761))
    code, _out, err = load(capsys, stdio("--bootloader"), img, sig)
    assert code == 2
    (line,) = error_lines(err)
    assert "Image too large (maximum 245760 bytes)" in line and "245761 bytes" in line
    assert "upload" not in err          # no progress: nothing was sent after the refusal


def test_signature_length_is_refused(capsys, tmp_path):
    img, sig = files(tmp_path, image_of("R7"), bytes(63))
    code, _out, err = load(capsys, stdio("--bootloader"), img, sig)
    assert code == 2
    (line,) = error_lines(err)
    assert "Incorrect signature length (should be64 bytes)" in line and "63 bytes" in line


def test_wrong_signature_is_refused_and_a_right_one_boots(capsys, tmp_path):
    private, key = new_key(str(tmp_path))
    image = image_of("R6")
    img, sig = files(tmp_path, image, sign(private, image + b"other"))
    code, _out, err = load(capsys, stdio("--bootloader", "--bootloader-key", key), img, sig)
    assert code == 2
    (line,) = error_lines(err)
    assert "Image verification failed" in line
    img, sig = files(tmp_path, image, sign(private, image))
    code, out, err = load(capsys, stdio("--bootloader", "--bootloader-key", key), img, sig)
    assert code == 0, err
    assert get_profile("R6").version_string in out


@pytest.mark.parametrize("which", ["image", "signature"])
def test_missing_file_is_usage(capsys, tmp_path, which):
    img, sig = files(tmp_path, image_of("R7"))
    if which == "image":
        img = str(tmp_path / "nope.bin")
    else:
        sig = str(tmp_path / "nope.sig")
    code, _out, err = load(capsys, stdio("--bootloader"), img, sig)
    assert code == 2
    (line,) = error_lines(err)
    assert "no such file" in line and "nope" in line


def test_unreachable_target_is_status_3(capsys, tmp_path):
    img, sig = files(tmp_path, image_of("R7"))
    code, _out, err = load(capsys, "/dev/ttyNOPE", img, sig)
    assert code == 3
    assert len(error_lines(err)) == 1 and "Traceback" not in err


# -- pacing and progress -----------------------------------------------------------------------

class Recorder(Target):
    """Records when each write happened on a fake clock; answers nothing."""

    url = "recorder"

    def __init__(self, clock):
        self.clock = clock
        self.writes = []

    def open(self):
        self.is_open = True

    def write(self, data):
        self.writes.append((self.clock.t, len(data)))

    def read(self, timeout):
        return b""

    def close(self):
        pass


class FakeClock:
    def __init__(self):
        self.t = 100.0

    def __call__(self):
        return self.t

    def sleep(self, s):
        assert s > 0
        self.t += s


@pytest.mark.parametrize("baud", [115200, 9600])
def test_upload_is_never_ahead_of_the_wire(baud):
    clock = FakeClock()
    target = Recorder(clock)
    client = BootloaderClient(Wire(target, clock=clock), baud=baud, chunk=100, sleep=clock.sleep)
    data = bytes(5000)
    client._paced(data, "image", show=False)
    offset = 0
    for t, n in target.writes:
        # a chunk starting at byte `offset` goes out no sooner than `offset` bytes take on the wire
        assert t - 100.0 >= wire_seconds(offset, baud) - 1e-9
        offset += n
    assert offset == len(data)
    # and no slower than needed: the last chunk leaves when the bytes before it have crossed
    assert target.writes[-1][0] - 100.0 == pytest.approx(wire_seconds(offset - target.writes[-1][1], baud))


def test_progress_on_a_terminal_is_one_redrawn_bar():
    clock = FakeClock()
    out = io.StringIO()
    bar = Progress(1000, "image", stream=out, tty=True, clock=clock)
    for done in range(0, 1001, 50):
        clock.t += 0.1
        bar.update(done)
    bar.finish(1000)
    text = out.getvalue()
    assert text.count("\n") == 1 and text.endswith("\n")
    assert "\r[" in text and "100% 1000/1000 bytes" in text


def test_progress_without_a_terminal_is_a_few_plain_lines():
    clock = FakeClock()
    out = io.StringIO()
    bar = Progress(1000, "image", stream=out, tty=False, clock=clock)
    for done in range(0, 1001, 10):
        clock.t += 0.1                      # 10 s in all: a line every 2 s, and the last
        bar.update(done)
    bar.finish(1000)
    lines = out.getvalue().splitlines()
    assert "\r" not in out.getvalue()
    assert 4 <= len(lines) <= 7
    assert lines[-1].startswith("image: 100% 1000/1000 bytes")


def test_image_describes_its_release():
    fw = FirmwareImage(image_of("R2"), bytes(64))
    assert "release R2 (1636109636)" in fw.describe()
    assert FirmwareImage(b"abc", bytes(64)).release is None


# -- the release image of python-build-hat, then the suite on it ---------------------------------

def _release_files():
    from hostlib import venvs

    python = venvs.buildhat_python("0.9.0")     # from PyPI: a failed install fails (the test is marked)
    data = subprocess.run([str(python), "-c", "import buildhat, os; print(os.path.join("
                           "os.path.dirname(buildhat.__file__), 'data'))"], capture_output=True, text=True,
                          check=True).stdout.strip()
    return pathlib.Path(data) / "firmware.bin", pathlib.Path(data) / "signature.bin"


@pytest.mark.slow
@pytest.mark.network
def test_release_image_through_a_pty_then_the_suite_passes_on_it(tmp_path):
    image, signature = _release_files()
    link = tmp_path / "hat"
    emu = subprocess.Popen([EMULATOR, "--pty", "--bootloader", "--link", str(link)], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        assert emu.stdout is not None
        emu.stdout.readline()                      # the pty path: it is up
        junit = tmp_path / "junit.xml"
        run = subprocess.run([str(BIN / "buildhat-conformance"), "run", "--target", str(link),
                              "--image", str(image), "--signature", str(signature), "--junit", str(junit),
                              "-k", "test_version or test_signature"],
                             capture_output=True, text=True, timeout=300)
        assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
        assert "loaded: firmware version 1737564117" in run.stdout
        load_transcript = (tmp_path / "load.jsonl").read_text()
        assert "Checksum OK" in load_transcript and "Image verifed OK" in load_transcript
        assert 'failures="0"' in junit.read_text() or "failures=\"0\"" in junit.read_text()
    finally:
        emu.terminate()
        emu.wait(timeout=10)
