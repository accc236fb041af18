"""The emulator against the firmware in the loop, same world (issue 37): every scenario script of
transcripts/data/ and transcripts/data/timing/ runs on ``sil:<R7 tree>`` and on the emulator (R7, a
115200-baud wire, as a HAT), from the same power-on, and the two runs' lines are compared in order
and by time (transcripts/same_world.py).

What is tolerated, and why: a line's time within ±1 ms (both sides are read every millisecond; the
firmware writes inside its millisecond, the emulator on its tick); device data (reports, PID lines)
whose values differ, from the motor's noise the script does not fix, when the line is of the same
kind and in time (the wire's byte time is allowed for a length difference); a line that lands inside
another's echo a few bytes apart, and the run's last line cut a few bytes apart (the wire carries 11.5
bytes a millisecond). Scripts whose device data ``@data`` fixes (``EXACT``) allow no device noise: every
line equal. Known open differences are listed with their reason and marked ``xfail(strict)``:
the test fails the day they go away, so the list stays true."""
from __future__ import annotations

import pathlib

import pytest
from sil_support import firmware_tree

from buildhat_conformance.emulator.api import Emulator
from buildhat_conformance.sil.target import from_url
from buildhat_conformance.transcripts.same_world import DATA_LINE, compare, run_lines
from buildhat_conformance.transcripts.script import Script, load_script, parse_script

pytestmark = pytest.mark.timeout(600)

DATA = pathlib.Path(__file__).resolve().parents[2] / "transcripts" / "data"
SCRIPTS = sorted(DATA.glob("*.script")) + sorted((DATA / "timing").glob("*.script"))
OPEN = {
    "hotplug.script": "`connecting` and every line after it come 12-13 ms later on the firmware in the "
                      "loop than on the emulator (port 3's scan phase at scenario time 0); not yet "
                      "explained: with the stand-in's idle skip off (a scratch copy, before the skip "
                      "kept the polling phase) every line agreed but 6 of the motor's set-up dump",
    "adc.script": "the emulator runs a line in the millisecond after its CR lands (its output timed to "
                  "match the firmware's), so a `vin` sent in the millisecond of an `@adc` reads the "
                  "conversion one tick later than the firmware, which reads the conversion its tick "
                  "before the CR started (docs/FIRMWARE-BEHAVIOUR.md#fb-vin): the new level 1 ms early",
}
# Scripts whose device data is all fixed by @data: no device noise to allow for, so every line must be
# equal (the PID lines' integrator values included, issue 37).
EXACT = {"pid-tick.script", "pid-nan.script"}


def firmware(script: Script):
    return from_url(f"sil:{firmware_tree()}?booted=0").new_hat(devices=script.devices)


def emulator(script: Script) -> Emulator:
    return Emulator(firmware="R7", devices=script.devices, baud=115200)


def _param(path: pathlib.Path):
    marks = [pytest.mark.xfail(strict=True, reason=OPEN[path.name])] if path.name in OPEN else []
    return pytest.param(path, id=path.name, marks=marks)


@pytest.mark.parametrize("path", [_param(p) for p in SCRIPTS])
def test_same_world(path):
    script = load_script(path)
    fw, emu = run_lines(firmware(script), script), run_lines(emulator(script), script)
    result = compare(fw, emu, noise=None if path.name in EXACT else DATA_LINE)
    assert result.ok, f"{path.name}: {result.summary()}\n" + "\n".join(result.differences[:20])


@pytest.mark.xfail(strict=True, reason="8 lines of the devices' set-up dumps come 2 ms later on the "
                   "firmware: what printing the dump costs the firmware's main loop, which the "
                   "emulator does not model")
def test_start_up_timeline_from_power_on():
    # The banner, the driver dumps, `Done initialising ports`, the connect lines, the set-ups at
    # 2400 baud and the first data, all on the scenario's clock from power-on.
    script = parse_script("@wait 3400\n> port 0 ; select 2\n@wait 60\n> select\n")
    fw = run_lines(firmware(script), script, boot=False)
    emu = run_lines(emulator(script), script, boot=False)
    result = compare(fw, emu, noise=DATA_LINE)
    assert result.ok, result.summary() + "\n" + "\n".join(result.differences[:20])
    done = [t for t, line in fw if line == "Done initialising ports"]
    assert done and 400 <= done[0] <= 410


def test_nan_signs_follow_the_firmware():
    # issue 37: with identical inputs the firmware printed cv=-NaN where the emulator printed cv=NaN.
    script = load_script(DATA / "timing" / "pid-nan.script")
    pid = [line for _, line in run_lines(firmware(script), script) if line.startswith("P0: pv=")]
    emu = [line for _, line in run_lines(emulator(script), script) if line.startswith("P0: pv=")]
    assert "P0: pv=Inf sp=0.00000: e=Inf ie=NaN de=-NaN cv=-NaN" in pid
    assert sorted(set(pid)) == sorted(set(emu))
