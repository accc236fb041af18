"""`?reset=gpio` (harness/targets/gpio_reset.py): the RESET/BOOT0 sequence through the gpiod 2.x request
API, on a fake chip; and `load` resetting a running HAT through it (the fake chip's RESET edge resets an
emulator through its control channel, as the wire would a real HAT)."""
from __future__ import annotations

import os
import pathlib
import subprocess
import sys
import time

import gpiod
import pytest
from firmware_images import image_of  # noqa: E402
from gpiod.line import Direction, Value
from target_kinds import make_target_of

from buildhat_conformance.emulator.targets.pty_process import EmulatorControl
from buildhat_conformance.harness.bootloader import load_firmware
from buildhat_conformance.harness.bootloader.image import FirmwareImage
from buildhat_conformance.harness.targets import TargetError, make_target
from buildhat_conformance.harness.targets.gpio_reset import BOOT0_LINE, RESET_LINE, GpioReset
from buildhat_conformance.harness.targets.serial_device import SerialTarget
from buildhat_conformance.protocol.profiles import get_profile

EMULATOR = str(pathlib.Path(sys.executable).parent / "buildhat-emulator")


class FakeRequest:
    """The part of gpiod.LineRequest the reset uses; every call is logged on the chip."""

    def __init__(self, chip, config):
        self.chip, self.config = chip, config
        self.released = False

    def set_value(self, line, value):
        assert not self.released
        assert isinstance(value, Value)
        self.chip.log.append(("set", line, value))
        self.chip.level[line] = value
        if self.chip.on_set is not None:
            self.chip.on_set(line, value)

    def release(self):
        self.released = True
        self.chip.log.append(("release",))


class FakeChip:
    """Stands for gpiod.request_lines: checks it is called as the real one is."""

    def __init__(self, on_set=None):
        self.log = []
        self.level = {}
        self.on_set = on_set
        self.requests = []

    def __call__(self, path, config, consumer=None, event_buffer_size=None, output_values=None):
        assert isinstance(path, str) and path.startswith("/dev/")
        for line, settings in config.items():
            assert isinstance(line, int)
            assert isinstance(settings, gpiod.LineSettings)
            assert settings.direction == Direction.OUTPUT
            self.level[line] = settings.output_value
        self.log.append(("request", path, {k: v.output_value for k, v in config.items()}, consumer))
        req = FakeRequest(self, config)
        self.requests.append(req)
        return req


def test_reset_pulse_is_the_official_sequence():
    chip, sleeps = FakeChip(), []
    GpioReset("/dev/gpiochip4", request_lines=chip, sleep=sleeps.append).reset(bootloader=True)
    # BOOT0 (22) low from the start, RESET (4) high, then low 10 ms, high 10 ms, release, 0.5 s
    levels = {BOOT0_LINE: Value.INACTIVE, RESET_LINE: Value.ACTIVE}
    assert chip.log[0] == ("request", "/dev/gpiochip4", levels, "buildhat-conformance")
    assert chip.log[1:] == [("set", 4, Value.INACTIVE), ("set", 4, Value.ACTIVE), ("release",)]
    assert sleeps == [0.01, 0.01, 0.5]
    assert chip.level[BOOT0_LINE] == Value.INACTIVE       # never raised: a raised BOOT0 is the USB ROM


def test_lines_and_chip_come_from_the_url():
    chip = FakeChip()
    t = make_target("serial:///dev/ttyAMA0?reset=gpio&chip=gpiochip4&reset_line=5&boot0_line=6",
                    request_lines=chip)
    assert t.has("reset") and t.has("bootloader") and not t.has("plug")
    assert isinstance(t.control, GpioReset)
    t.control.sleep = lambda s: None
    t.control.reset()
    assert chip.log[0][1] == "/dev/gpiochip4" and set(chip.log[0][2]) == {5, 6}
    assert ("set", 5, Value.INACTIVE) in chip.log
    plain = make_target_of(SerialTarget, "/dev/ttyAMA0?reset=gpio", request_lines=chip)
    assert isinstance(plain.control, GpioReset)
    assert plain.path == "/dev/ttyAMA0" and plain.control.chip == "/dev/gpiochip0"


@pytest.mark.parametrize("url, words", [
    ("/dev/ttyAMA0?reset=relay", "reset=gpio"),
    ("/dev/ttyAMA0?chip=gpiochip0", "only with reset=gpio"),
    ("/dev/ttyAMA0?reset=gpio&reset_line=four", "GPIO line number"),
    ("/dev/ttyAMA0?reset=gpio&reset_line=22", "two lines"),
])
def test_bad_gpio_options_are_one_line(url, words):
    with pytest.raises(TargetError, match=words) as info:
        make_target(url, request_lines=FakeChip())
    assert "\n" not in str(info.value)


def test_missing_chip_says_what_to_check():
    with pytest.raises(TargetError, match="gpiodetect"):
        GpioReset("/dev/gpiochip99", sleep=lambda s: None).reset()


def test_world_actions_are_not_a_gpio_reset():
    from buildhat_conformance.harness.targets import NeedsCapability
    with pytest.raises(NeedsCapability):
        GpioReset(request_lines=FakeChip()).action("@plug 1 0x30")


def test_load_resets_a_running_hat_through_gpio(tmp_path):
    sock = str(tmp_path / "control.sock")
    emu = subprocess.Popen([EMULATOR, "--pty", "--booted", "--control", sock], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True, start_new_session=True)
    control = EmulatorControl(sock)
    try:
        pty = emu.stdout.readline().strip()
        control.connect(time.monotonic() + 20)
        # the wire: RESET rising again after it was low restarts the HAT (in its bootloader: BOOT0 low)
        def wire(line, value):
            if line == RESET_LINE and value == Value.ACTIVE and chip.level.get(BOOT0_LINE) == Value.INACTIVE:
                control.reset(bootloader=True)
        chip = FakeChip(on_set=wire)
        target = make_target(f"{pty}?reset=gpio", request_lines=chip)
        assert isinstance(target.control, GpioReset)
        target.control.sleep = lambda s: None if s < 0.1 else time.sleep(0.1)
        fw = FirmwareImage(image_of("R4"), bytes(64))
        with target:
            result = load_firmware(target, fw, progress_stream=open(os.devnull, "w"), tty=False)
        assert result.reset
        assert result.firmware_version == get_profile("R4").version_string
        assert [e for e in chip.log if e[0] == "release"]
    finally:
        control.close()
        emu.terminate()
        emu.wait(timeout=10)
