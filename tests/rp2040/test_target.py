"""The rp2040: target: what its URL means, the one line for each missing piece, and a released image
booted on the emulated chip answering as the release's profile says (protocol/profiles.json)."""
from __future__ import annotations

import os
import subprocess
import sys
import zipfile

import pytest
from rp2040_support import bootrom, image_wheels, rp2040js

from buildhat_conformance.harness.targets import make_target
from buildhat_conformance.harness.targets.base import NeedsCapability, TargetError
from buildhat_conformance.protocol.profiles import get_profile
from buildhat_conformance.rp2040 import images, install
from buildhat_conformance.rp2040.chip import unwired_plug
from buildhat_conformance.rp2040.target import Rp2040Target, from_url

CLI = [sys.executable, "-m", "buildhat_conformance.cli"]


def wheel(folder, version: str, release: int, image: bytes = b"\x00" * 64):
    """A buildhat wheel of the test's own: an image and its version file where buildhat keeps them."""
    path = folder / f"buildhat-{version}-py3-none-any.whl"
    with zipfile.ZipFile(path, "w") as whl:
        whl.writestr("buildhat/data/firmware.bin", image)
        whl.writestr("buildhat/data/version", f"{release}\n")
    return path


@pytest.fixture()
def own_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    return tmp_path


def test_a_release_is_found_among_wheels_by_its_version_file(own_cache):
    folder = own_cache / "imgs"
    folder.mkdir()
    wheel(folder, "0.5.8", get_profile("R3").number, b"R3 image")
    wheel(folder, "0.9.0", get_profile("R7").number, b"R7 image")
    found = images.find_image("R3", str(folder))
    assert found.release == get_profile("R3").number
    assert found.path.read_bytes() == b"R3 image"
    assert images.find_image("1737564117", str(folder)).path.read_bytes() == b"R7 image"


def test_an_unpacked_image_is_found_beside_its_version_file(tmp_path):
    data = tmp_path / "0.5.4" / "buildhat" / "data"
    data.mkdir(parents=True)
    (data / "firmware.bin").write_bytes(b"R1 image")
    (data / "version").write_text(f"{get_profile('R1').number}\n")
    assert images.find_image("R1", str(tmp_path)).path == data / "firmware.bin"


def test_a_missing_release_is_one_line_naming_what_to_do(own_cache):
    with pytest.raises(TargetError) as err:
        images.find_image("R4", str(own_cache))
    message = str(err.value)
    assert "\n" not in message and "R4 (1670332907)" in message and "?images=DIR" in message


def test_an_image_path_is_taken_as_it_is(tmp_path):
    image = tmp_path / "firmware.bin"
    image.write_bytes(b"\x00" * 8)
    assert images.find_image(str(image)).path == image.resolve()
    with pytest.raises(TargetError, match="no firmware image at"):
        images.find_image(str(tmp_path / "nothing.bin"))


def test_an_unknown_release_is_refused():
    with pytest.raises(TargetError, match="unknown firmware 'R9'"):
        images.find_image("R9")


def test_the_boot_rom_comes_from_the_url_the_environment_or_the_default_place(own_cache, monkeypatch):
    rom = own_cache / "rom.bin"
    rom.write_bytes(bytes(16 * 1024))
    monkeypatch.delenv(install.BOOTROM_ENV, raising=False)
    with pytest.raises(TargetError) as err:
        install.find_bootrom()
    assert "\n" not in str(err.value) and str(install.default_bootrom()) in str(err.value)
    assert install.find_bootrom(str(rom)) == rom
    monkeypatch.setenv(install.BOOTROM_ENV, str(rom))
    assert install.find_bootrom() == rom
    rom.write_bytes(b"short")
    with pytest.raises(TargetError, match="not an RP2040 boot ROM"):
        install.find_bootrom()


def test_rp2040js_missing_says_to_run_setup(own_cache):
    with pytest.raises(TargetError, match="run 'buildhat-conformance rp2040 setup' once"):
        install.check_rp2040js()


def test_url_options_are_checked():
    with pytest.raises(TargetError, match="unknown option"):
        from_url("rp2040:R7?colour=red")
    with pytest.raises(TargetError, match="active devices are not yet wired"):
        from_url("rp2040:R7?device=0=0x30")
    with pytest.raises(TargetError, match="speed"):
        from_url("rp2040:R7?speed=1")


def test_an_active_plug_is_a_missing_capability_not_a_fault():
    assert unwired_plug("@plug 0 0x30")
    assert not unwired_plug("@plug 0 passive 8")
    assert not unwired_plug("@unplug 0")
    assert issubclass(NeedsCapability, TargetError)


def test_setup_installs_nothing_when_the_pinned_version_is_there():
    folder = rp2040js()
    done = subprocess.run(CLI + ["rp2040", "setup"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert str(folder) in done.stdout and install.RP2040JS_VERSION in done.stdout


def test_check_names_the_missing_boot_rom_in_one_line(tmp_path):
    env = dict(os.environ, XDG_CACHE_HOME=str(tmp_path))
    env.pop(install.BOOTROM_ENV, None)
    done = subprocess.run(CLI + ["rp2040", "check", "rp2040:R7"], capture_output=True, text=True, env=env,
                          timeout=60)
    assert done.returncode == 3
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("buildhat-conformance rp2040: ")


@pytest.fixture(scope="module")
def r7_url():
    rp2040js()
    return f"rp2040:R7?images={image_wheels('R7')}&bootrom={bootrom()}"


def answer(target, line: bytes, ms: int = 600) -> bytes:
    target.write(line + b"\r")
    target.advance(ms)
    return target.read(0.1)


def test_r7_boots_and_answers_as_its_profile_says(r7_url):
    profile = get_profile("R7")
    target = make_target(r7_url)
    assert isinstance(target, Rp2040Target)
    target.open()
    try:
        start = target.read(0.1)
        assert b"Done initialising ports\r\n" in start
        version = answer(target, b"version")
        assert f"Firmware version: {profile.version_string}\r\n".encode() in version
        assert profile.help_bytes in answer(target, b"help")
        # nothing on the ports (docs/FIRMWARE-BEHAVIOUR.md#fb-list: an empty port)
        listed = answer(target, b"list")
        assert all(f"P{p}: no device detected\r\n".encode() in listed for p in range(4))
        assert target.control is not None
        assert target.control.action("@firmware") == f"ok {profile.version_string}"
    finally:
        target.close()


def test_two_runs_give_the_same_bytes_at_the_same_times(r7_url):
    runs = []
    for _ in range(2):
        target = make_target(r7_url)
        target.open()
        try:
            got = [(target.now, target.read(0.1))]      # type: ignore[attr-defined]
            got.append((target.now, answer(target, b"version", 200)))  # type: ignore[attr-defined]
            runs.append(got)
        finally:
            target.close()
    assert runs[0] == runs[1]


@pytest.mark.parametrize("release", ["R1", "R2", "R3", "R5", "R6"])
def test_every_released_image_answers_as_its_profile_says(release):
    """Each release's shipped image (R2 and R3 exist only as binaries) answers `version` and `help` as
    the project's profile of that release says."""
    rp2040js()
    profile = get_profile(release)
    target = make_target(f"rp2040:{release}?images={image_wheels(release)}&bootrom={bootrom()}")
    target.open()
    try:
        assert b"Done initialising ports\r\n" in target.read(0.1)
        assert f"Firmware version: {profile.version_string}\r\n".encode() in answer(target, b"version", 200)
        assert profile.help_bytes in answer(target, b"help")
    finally:
        target.close()


def test_passive_devices_at_the_chips_pins_connect_and_disconnect(r7_url):
    """The ID lines' electrical model at the chip's pins: the released firmware sees passive devices
    plugged before and after its start-up, and their removal (docs/FIRMWARE-BEHAVIOUR.md#fb-list,
    #fb-disconnected)."""
    target = make_target(r7_url + "&device=0=passive 1")
    assert isinstance(target, Rp2040Target)
    target.open()
    try:
        assert b"P0: connected to passive ID 1\r\n" in target.read(0.1)
        assert target.control is not None
        target.control.action("@plug 3 passive 8")
        target.advance(1500)
        assert target.read(0.1) == b"P3: connected to passive ID 8\r\n"
        target.control.action("@unplug 0")
        target.advance(1500)
        assert target.read(0.1) == b"P0: disconnected\r\n"
    finally:
        target.close()
