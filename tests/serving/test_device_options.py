"""Devices on the ports as every served HAT takes them (serving/device_options.py): one line for
every bad option, naming the URL's scheme or the option."""
from __future__ import annotations

import argparse

import pytest

from buildhat_conformance.harness.targets.base import TargetError
from buildhat_conformance.serving.device_options import device_options, url_devices


def test_a_url_layout() -> None:
    layout = url_devices(["0=0x30", "2=passive 5"], "sil")
    assert sorted(layout) == [0, 2]
    assert layout[0] is not None and layout[2] is not None


@pytest.mark.parametrize("value, said", [("0x30", "sil: device option must be P=SPEC"),
                                         ("x=0x30", "sil: device option must be P=SPEC"),
                                         ("1=0xZZ", "sil: device '1=0xZZ': ")])
def test_a_bad_url_device_is_one_target_error_naming_the_scheme(value: str, said: str) -> None:
    with pytest.raises(TargetError) as info:
        url_devices([value], "sil")
    assert str(info.value).startswith(said) and "\n" not in str(info.value)


def test_a_bad_device_option_is_the_parsers_one_line_error(capsys: pytest.CaptureFixture) -> None:
    parser = argparse.ArgumentParser(prog="prog")
    assert device_options(["3=0x30"], parser).keys() == {3}
    with pytest.raises(SystemExit):
        device_options(["4=0x30"], parser)
    assert "--device '4=0x30': expected P=SPEC with P in 0..3" in capsys.readouterr().err
