"""The device catalogue (protocol/devices.py, devices.json): the shared original and device specs."""
import json

import pytest
from shared_material import need_shared

from buildhat_conformance.protocol import devices


def test_device_catalogue_is_the_shared_copy():
    original = need_shared("protocol", "devices.json", what="the original of protocol/devices.json")
    shared = json.loads(original.read_text(encoding="utf-8"))
    assert devices.catalogue() == shared


def test_device_specs():
    assert devices.parse_device_spec("0x30") == ("active", 0x30)
    assert devices.parse_device_spec("passive  8") == ("passive", 8)
    assert devices.parse_device_spec("none") is None
    with pytest.raises(ValueError):
        devices.parse_device_spec("passive 12")
    with pytest.raises(KeyError):
        devices.parse_device_spec("0x99")
