"""``buildhat-conformance targets``: what this machine can run against.

Lists the serial ports pyserial sees (with the Raspberry Pi 5 remark where
``/dev/serial0`` is the debug UART), the emulator's firmware releases, and the URL forms.
Nothing is opened, so listing never disturbs a HAT. With a labgrid coordinator (``--coordinator``
or ``LG_COORDINATOR``) it also lists the lab's places: free, or held by whom (harness/lab/).
"""
# The folders install under this package's name (setup.py maps harness/ to
# buildhat_conformance.harness ...); pyright reads the checkout, where they sit beside this folder.
# pyright: reportMissingImports=false
from __future__ import annotations

import argparse
import glob
import os
from typing import List

from serial.tools import list_ports

from .emulator.targets.pty_process import emulator_command
from .harness.targets import TargetError, url_forms
from .harness.targets.serial_device import pi5_debug_uart_remark
from .plumbing.cli_options import DEFAULT_SPEED
from .protocol.profiles import DEFAULT_FIRMWARE, load_profiles

# Raspberry Pi aliases that list_ports may not report (they are symlinks).
_PI_LINKS = ("/dev/serial0", "/dev/serial1")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--all", action="store_true", help="also list ports without a description (ttyS*)")
    parser.add_argument("--coordinator", default="", metavar="HOST:PORT",
                        help="also list this labgrid coordinator's places (default: LG_COORDINATOR if set)")


def lab_lines(coordinator: str) -> List[str]:
    """One line per place of the lab: name, free or who holds it, tags. TargetError when the
    coordinator cannot be asked (labgrid missing, nothing listening)."""
    from .harness.lab.client import client_for

    client = client_for(coordinator)
    lines = [f"Lab places (labgrid coordinator {client.address}; this user is {client.me}):"]
    states = client.places()
    for s in states:
        tags = " ".join(f"{k}={v}" for k, v in sorted(s.tags.items()))
        lines.append(f"  labgrid:{s.name:<22} {s.holder_text():<28} {tags}".rstrip())
    if not states:
        lines.append("  none (labgrid-client -p NAME create; docs/LAB.md)")
    return lines


def serial_port_lines(show_all: bool = False) -> List[str]:
    lines = []
    ports = sorted(list_ports.comports(include_links=True), key=lambda p: p.device)
    seen = set()
    for p in ports:
        seen.add(p.device)
        described = p.description and p.description != "n/a"
        if not show_all and not described and not p.device.startswith(("/dev/ttyAMA", "/dev/serial")):
            continue
        text = f"  {p.device:<16} {p.description if described else ''}".rstrip()
        remark = pi5_debug_uart_remark(p.device)
        lines.append(text + (f"\n      ! {remark}" if remark else ""))
    for link in _PI_LINKS:
        if link not in seen and os.path.exists(link):
            real = os.path.realpath(link)
            remark = pi5_debug_uart_remark(link)
            lines.append(f"  {link:<16} -> {real}" + (f"\n      ! {remark}" if remark else ""))
    if not lines:
        hidden = len(glob.glob("/dev/ttyS*"))
        lines.append("  none found" + (f" ({hidden} /dev/ttyS* hidden; --all shows them)" if hidden else ""))
    return lines


def emulator_lines() -> List[str]:
    try:
        cmd = " ".join(emulator_command())
        where = f"buildhat-emulator: {cmd}"
    except TargetError as exc:
        where = f"buildhat-emulator: not available ({exc})"
    lines = [f"  {where}"]
    for number, p in load_profiles().items():
        mark = "  (latest, default)" if number == DEFAULT_FIRMWARE else ""
        # the version string starts with the number: print it once, then the build date
        rest = p.version_string[len(str(number)):].strip() if p.version_string.startswith(str(number)) \
            else p.version_string
        lines.append(f"  emulator:{p.name:<4} {number}  {rest}{mark}".rstrip())
    return lines


# Options of the URLs (emulator/targets/pty_process.py, inprocess.py, sil/target.py, serial.py from_url).
URL_OPTIONS = [
    ("emulator: speed=N", "N times real time (default 10 for a bare 'emulator'; speed=1: real time)"),
    ("emulator: device=P=SPEC", "start-up layout, e.g. device=1=0x30 or device=2=passive+8 (repeatable)"),
    ("emulator: booted=1", "start powered up, devices established (start-up in virtual time)"),
    ("emulator: bootloader=1", "start in the bootloader (BHBL>), as a HAT after power-on"),
    ("emulator: baud=N", "pace the output as a UART at N baud"),
    ("emulator: seed=N", "seed of the emulated sensors' noise"),
    ("inprocess: device=, seed=, baud=", "as for emulator"),
    ("inprocess: scale=S, boot=0", "virtual-time scale; boot=0 starts before the start-up"),
    ("sil: device=, seed=", "as for emulator (the world's device models around the firmware)"),
    ("sil: booted=0", "open before the start-up (default: a HAT whose start-up is done)"),
    ("sil: sanitize=address,undefined", "build with sanitizers (as sil build --sanitize)"),
    ("sil: coverage=1", "build with gcov coverage of the firmware's files (sil coverage)"),
    ("sil: firmware=RELEASE", "the release whose device-side timing the world uses (default latest)"),
    ("sil: speed=N", "paced to the wall clock, N times real time, on a pty (for host libraries)"),
    ("sil: suppressions=FILE", "sanitizer reports acknowledged in FILE (the sanitizers' kind:pattern lines) "
                               "are listed as suppressed, not failed"),
    ("serial: baud=N", "serial:///dev/ttyAMA0?baud=N (default 115200)"),
    ("serial: reset=gpio", "reset the HAT through a Raspberry Pi's GPIO (gpio extra; docs/LAB.md)"),
    ("  chip=, reset_line=, boot0_line=", "with reset=gpio (default /dev/gpiochip0, 4, 22)"),
    ("labgrid: coordinator=HOST:PORT", "the lab's coordinator (default LG_COORDINATOR; lab extra)"),
    ("labgrid: wait=S", "wait up to S seconds for a held place"),
    ("  reset_output=, boot0_output=", "the place's digital outputs (default reset, boot0)"),
    ("  serial=NAME", "the place's serial port, when it has several"),
]


def main(args: argparse.Namespace) -> int:
    print("Serial ports:")
    print("\n".join(serial_port_lines(args.all)))
    print("\nEmulator releases:")
    print("\n".join(emulator_lines()))
    print("\nTarget URLs:")
    for form, meaning in url_forms():
        print(f"  {form:<52} {meaning}")
    print("\nURL options (?name=value&...):")
    for form, meaning in URL_OPTIONS:
        print(f"  {form:<34} {meaning}")
    print(f"\nDefault target: emulator = emulator:latest?speed={DEFAULT_SPEED:g}")
    coordinator = args.coordinator or os.environ.get("LG_COORDINATOR", "")
    if coordinator:
        print()
        print("\n".join(lab_lines(coordinator)))     # a TargetError is one line, exit 3 (cli_dispatch)
    return 0
