"""sil/host_lint.py: the host lint of a served firmware keeps its shadow in step with the firmware (time,
a power-cycle) and reads the host's lines as the release the firmware reports. Expectations from
docs/FIRMWARE-BEHAVIOUR.md: R7 has no `bias` (#fb-pid-error's release notes, section 12) and a CR ends a
line (#fb-cr)."""
from __future__ import annotations

import pytest
from sil_support import cli, firmware_tree

from buildhat_conformance.sil.host_lint import FirmwareLint

pytestmark = pytest.mark.timeout(600)


@pytest.fixture()
def hat(tmp_path, monkeypatch):
    from buildhat_conformance.sil.serve import _hat, build_parser
    tree = firmware_tree()
    assert cli("sil", "build", str(tree), cache=tmp_path).returncode == 0
    monkeypatch.setenv("BUILDHAT_SIL_CACHE", str(tmp_path))
    parser = build_parser()
    served = _hat(parser.parse_args([str(tree), "--stdio"]), parser)
    served.boot()
    yield served
    served.close()


def test_the_shadow_keeps_the_firmwares_time_and_power_cycles(hat):
    lint = FirmwareLint(profile_of=lambda: None, firmware=hat, release="R7", booted=True)
    lint.follow(hat)
    assert lint.profile_of().name == "R7"
    lint.feed_input(b"bias 0\r")
    hat.write(b"bias 0\r")
    hat.advance(20)
    lint.follow(hat)
    assert lint.lines == 1 and lint.counts["not_in_profile"] == 1 and lint.counts["error"] == 1
    hat.world("@reset")                 # a new firmware process: the shadow is power-cycled with it
    lint.follow(hat)
    hat.advance(3000)
    lint.follow(hat)
    lint.feed_input(b"vin\r")
    hat.write(b"vin\r")
    hat.advance(20)
    lint.follow(hat)
    assert lint.lines == 2 and lint.counts["error"] == 1
    assert lint.counts["before_ready"] == 0, lint.summary()
