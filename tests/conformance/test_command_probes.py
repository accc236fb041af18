"""Prefix probes that hold on hardware (conformance/command_probes.py): which of pid / pid_diff a token ran
is read off the motor's own position, whatever it is (at rest on 0, on 100, jittering +-1), with no world
control. The rule (:func:`pid_or_diff`) comes from FIRMWARE-FACTS §7.2: pid's process value is the position,
pid_diff's is 100 x its change per tick."""
from __future__ import annotations

import pytest

from buildhat_conformance.conformance.command_probes import pid_or_diff, probe
from buildhat_conformance.conformance.hat_under_test import HatUnderTest
from buildhat_conformance.harness.session import Session
from buildhat_conformance.harness.targets import make_target

pytestmark = pytest.mark.timeout(120)


@pytest.mark.parametrize("pvs, positions, told", [
    ([0, 1, -1, 0, 1], [0, -1, 1], "pid"),          # at rest on 0, jittering: pid shows the +-1
    ([0, 100, -100, 0, 0], [0, -1, 1], "diff"),     # the same motor under pid_diff: +-100 per tick
    ([0, 0, 0, 0], [0, 0, 0], None),                # exactly 0, still: both print 0 - move it first
    ([37, 37, 37], [37, 37], "pid"),                 # still elsewhere: pid shows the angle
    ([0, 0, 0], [37, 37], "diff"),                   # ... pid_diff shows 0
    ([100, 100, 100], [100, 100], None),             # still on 100: a position and a multiple of 100
    ([99, 100, 101], [100, 99], "pid"),
    ([0, 100, 0, -100], [100, 101, 99], "diff"),     # near 100, pid could not print 0 or -100
    ([-179, 179, -180], [-180, 179], "pid"),         # the wrap of APOS
])
def test_pid_or_diff_from_the_values_alone(pvs, positions, told):
    assert pid_or_diff([float(v) for v in pvs], [float(p) for p in positions]) == told


def _read(hat: HatUnderTest, port: int, mode: int) -> int:
    head = f"P{port}M{mode}:"
    hat.exchange(f"port {port} ; selonce {mode}")
    seen = hat.wait_for(lambda e: getattr(e, "text", "").startswith(head), 1, 1500)
    return int([e.text for e in seen if e.text.startswith(head)][-1].split(":")[1].split()[0])


def _put_apos(hat: HatUnderTest, port: int, angle: int) -> None:
    """Turn the shaft so that APOS (mode 3, what the probe reads) shows ``angle``: ``@pos`` sets POS,
    and APOS moves with it by the same amount."""
    pos, apos = _read(hat, port, 2), _read(hat, port, 3)
    delta = (angle - apos + 180) % 360 - 180
    hat.world(f"@pos {port} {pos + delta}")
    assert abs(_read(hat, port, 3) - angle) <= 1


def _hat(url: str):
    target = make_target(url)
    session = Session(target).open()
    return HatUnderTest(session, target, url), session


@pytest.mark.parametrize("angle", [None, 0, 100, -37])
@pytest.mark.parametrize("token, command", [("pid", "pid"), ("pid_", "pid_diff"), ("pid_diff", "pid_diff"),
                                            ("pi", "pid")])
def test_pid_probes_on_a_resting_motor(angle, token, command):
    # The in-process emulator: its motor jitters +-1 at rest as real ones do; the shaft is turned by hand
    # so that APOS rests on the angle (None: wherever it powered up).
    hat, session = _hat("inprocess:R7?seed=3")
    try:
        port = 0                                             # the default layout's motor
        hat.resync()
        if angle is not None:
            _put_apos(hat, port, angle)
            hat.resync()
        out = probe(hat, port, command, token)
        assert out.ran, f"`{token}` should run {command}; seen {out.seen}"
        # and the other one must not be taken for it
        other = "pid_diff" if command == "pid" else "pid"
        hat.resync()
        assert not probe(hat, port, other, token).ran
    finally:
        session.close()


def test_pid_probe_through_a_command_target_without_control():
    import shlex
    import sys
    from pathlib import Path

    emulator = str(Path(sys.executable).parent / "buildhat-emulator")
    url = "cmd:" + shlex.join([emulator, "--stdio", "--booted"])
    hat, session = _hat(url)
    try:
        assert not hat.target.has("data")
        hat.resync()
        assert probe(hat, 0, "pid", "pid").ran
        assert probe(hat, 0, "pid_diff", "pid_").ran
        assert not probe(hat, 0, "pid_diff", "pi").ran
    finally:
        session.close()


def test_when_the_values_cannot_tell_the_probe_moves_the_motor(monkeypatch):
    # A motor resting on exactly 0 without jitter gives pid and pid_diff the same values; the emulator's
    # motor always jitters, so the first look is made to say "cannot tell" and the probe must move it.
    from buildhat_conformance.conformance import command_probes

    real = command_probes.pid_or_diff
    looks = []

    def first_undecided(pvs, positions):
        looks.append(list(positions))
        return None if len(looks) == 1 else real(pvs, positions)

    monkeypatch.setattr(command_probes, "pid_or_diff", first_undecided)
    hat, session = _hat("inprocess:R7?seed=5")
    try:
        hat.resync()
        _put_apos(hat, 0, 0)
        hat.resync()
        assert probe(hat, 0, "pid", "pid").ran
        assert len(looks) == 2
        # _put_apos leaves the reading within 1 of 0 and the encoder flickers +-1 around the true
        # angle (emulator/devices/motor.py): a resting motor reads at most 2 from 0.
        assert all(abs(p) <= 2 for p in looks[0]), looks
        assert all(abs(p) > 5 for p in looks[1]), f"the motor did not move: {looks}"
    finally:
        session.close()
