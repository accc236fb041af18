"""Issue 13 item 2: `run` resets a dead HAT once and goes on (conformance/plugin/recovery.py).

The HAT under test hangs mid-run (the emulator's fault injection, emulator/hang.py: after the
host's Nth line it neither reads nor prints until a reset). Each run is the user's own command,
`buildhat-conformance run`, in a subprocess:

- in virtual time (`inprocess:?hang_after=N`): the emulator is reset through its control; the
  cases after the reset get the verdicts a run without the hang gives them;
- as on a Raspberry Pi: the emulator behind its own pty, the target `PTY?reset=gpio`, and a
  `gpiod` stand-in (tests/fake_gpiod) whose RESET/BOOT0 lines are the emulator's pins, so the HAT
  restarts in its bootloader as a real one does: with `--image/--signature` the run loads the
  release again and goes on; without them it stops in one line.
"""
from __future__ import annotations

import os
import pathlib
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest
from firmware_images import files, image_of  # noqa: E402
from junit_props import properties, suite_properties
from repo_paths import TESTS  # noqa: E402

BIN = pathlib.Path(sys.executable).parent
FAKE_GPIOD = TESTS / "fake_gpiod"
SUBSET = "shortest_resolving_prefix"        # 28 short cases
# 14 of them, for the runs at real time: the hang (after the 60th line) still comes in the fifth or
# sixth, and seven or more follow it.
PI_SUBSET = SUBSET + " and not (pid or port or pwm or set or sel or sig or write or ver)"
MAX_FAULTS = 1       # the first target fault already resets: shorter runs


def run(tmp_path, name: str, target: str, *extra: str, env=None, keyword: str = SUBSET
        ) -> tuple[int, str, dict, dict]:
    junit = tmp_path / name / "junit.xml"
    proc = subprocess.run([str(BIN / "buildhat-conformance"), "run", "--target", target, "-k", keyword,
                           "--max-target-faults", str(MAX_FAULTS), "--junit", str(junit), *extra],
                          capture_output=True, text=True, timeout=300, env=env)
    root = ET.parse(junit).getroot()
    suite = suite_properties(root)
    verdicts = {}
    for case in root.iter("testcase"):
        props = properties(case)
        verdicts[case.get("name")] = props.get("verdict")
    return proc.returncode, proc.stdout + proc.stderr, suite, verdicts


def faulted(verdicts: dict) -> list:
    return [name for name, v in verdicts.items() if v == "target-fault"]


def test_a_hung_hat_is_reset_once_and_the_run_goes_on(tmp_path):
    code0, _out, _suite, clean = run(tmp_path, "clean", "inprocess")
    assert code0 == 0 and clean
    code, out, suite, hung = run(tmp_path, "hung", "inprocess:?hang_after=40")
    names = list(hung)
    faults = faulted(hung)
    # The hang costs the cases until the run resets the HAT: at most --max-target-faults of them.
    assert 1 <= len(faults) <= MAX_FAULTS, out
    assert "answers again" in suite.get("reset", ""), suite
    assert "stopped" not in suite
    after = names[names.index(faults[-1]) + 1:]
    assert after, "the hang came too late in the subset to show the run going on"
    assert {n: hung[n] for n in after} == {n: clean[n] for n in after}
    assert "reset the HAT once; it answers again" in out
    assert "reset: reset the HAT once; it answers again" in (tmp_path / "hung" / "index.html").read_text()
    assert code == 3          # the target faulted, and nothing failed the protocol


@pytest.fixture
def pi_hat(tmp_path):
    """An emulator as a HAT on a Raspberry Pi: its own pty, in its bootloader (as after power-on),
    hanging after the host's 60th line; a GPIO chip whose lines are its RESET and BOOT0 pins."""
    control = tmp_path / "control.sock"
    link = tmp_path / "hat"
    argv = [str(BIN / "buildhat-emulator"), "--pty", "--bootloader", "--control", str(control),
            "--link", str(link), "--hang-after", "60"]
    emu = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                           start_new_session=True)
    try:
        assert emu.stdout is not None and emu.stdout.readline().strip()
        chip = tmp_path / "gpiochip9"
        chip.touch()
        env = dict(os.environ, PYTHONPATH=str(FAKE_GPIOD), BUILDHAT_EMULATOR_CONTROL=str(control))
        yield f"{link}?reset=gpio&chip={chip}", env
    finally:
        emu.terminate()
        emu.wait(timeout=10)


def test_a_gpio_reset_lands_in_the_bootloader_and_the_release_is_loaded_again(tmp_path, pi_hat):
    target, env = pi_hat
    img, sig = files(tmp_path, image_of("R7"))
    code, out, suite, verdicts = run(tmp_path, "pi", target, "--image", img, "--signature", sig, env=env,
                                     keyword=PI_SUBSET)
    faults = faulted(verdicts)
    assert 1 <= len(faults) <= MAX_FAULTS, out
    assert f"loaded {img} again; it answers again" in suite.get("reset", ""), suite
    names = list(verdicts)
    after = names[names.index(faults[-1]) + 1:]
    assert len(after) >= 5, verdicts
    assert all(verdicts[n] in ("pass", "known deviation", "informational") for n in after), verdicts
    assert code == 3, out


def test_without_an_image_the_reset_cannot_bring_the_firmware_back(tmp_path, pi_hat):
    from buildhat_conformance.harness.bootloader import load_firmware
    from buildhat_conformance.harness.bootloader.image import FirmwareImage
    from buildhat_conformance.harness.targets import make_target

    target, env = pi_hat
    with make_target(target.split("?")[0]) as plain:      # the release loaded by hand, once
        load_firmware(plain, FirmwareImage(image_of("R7"), bytes(64)), progress_stream=open(os.devnull, "w"),
                      tty=False)
    code, out, suite, verdicts = run(tmp_path, "noimage", target, env=env, keyword=PI_SUBSET)
    assert "no --image/--signature to load the release again" in suite.get("stopped", ""), suite
    assert "reset the HAT once, in vain" in suite["reset"]
    faults = faulted(verdicts)
    assert 1 <= len(faults) <= MAX_FAULTS
    names = list(verdicts)
    assert all(verdicts[n] == "not-run" for n in names[names.index(faults[-1]) + 1:])
    assert code == 3
    assert "Traceback" not in out
