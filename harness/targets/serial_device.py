"""A HAT on a local serial port: ``/dev/serial0``, ``/dev/ttyAMA0``, ``/dev/ttyUSB0``, any
existing path, or ``serial:///dev/...?baud=115200``.

Opened 115200 8N1, no flow control, exclusively (a second opener gets a clear "busy").
Open failures are explained in terms of what to do: missing device, permissions
(``dialout``), busy port (who holds it), and the Raspberry Pi 5 trap where
``/dev/serial0`` is the debug UART ``ttyAMA10`` rather than the header UART.
"""
from __future__ import annotations

import errno
import os
from typing import List, Optional
from urllib.parse import parse_qs, unquote, urlsplit

import serial

from .base import TargetError
from .gpio_reset import GPIO_OPTIONS, gpio_reset_from_options
from .pyserial_base import BAUD, PyserialTarget

__all__ = ["SerialTarget", "from_url", "pi5_debug_uart_remark", "port_holders"]

PI5_DEBUG_UART = "ttyAMA10"


def pi5_debug_uart_remark(path: str) -> Optional[str]:
    """The Pi 5 remark for a path that resolves to the debug UART, else None."""
    real = os.path.realpath(path)
    if os.path.basename(real) != PI5_DEBUG_UART:
        return None
    via = f"{path} -> {real}" if real != path else path
    return (f"{via} is the Raspberry Pi 5 debug UART (the 3-pin connector between the HDMI ports), "
            "not the GPIO-header UART the Build HAT is on. Use /dev/ttyAMA0 instead (enable it with "
            "'dtparam=uart0=on' in /boot/firmware/config.txt and reboot).")


def port_holders(path: str) -> List[str]:
    """'pid (name)' of every process with the device open, found through /proc (Linux)."""
    real = os.path.realpath(path)
    out = []
    try:
        pids = [p for p in os.listdir("/proc") if p.isdigit()]
    except OSError:
        return out
    for pid in pids:
        fd_dir = f"/proc/{pid}/fd"
        try:
            fds = os.listdir(fd_dir)
        except OSError:
            continue
        for fd in fds:
            try:
                if os.readlink(f"{fd_dir}/{fd}") == real:
                    break
            except OSError:
                continue
        else:
            continue
        try:
            with open(f"/proc/{pid}/comm", encoding="utf-8") as fh:
                name = fh.read().strip()
        except OSError:
            name = "?"
        out.append(f"{pid} ({name})" + (" (this process)" if int(pid) == os.getpid() else ""))
    return out


class SerialTarget(PyserialTarget):
    """A local serial device, opened exclusively."""

    def __init__(self, path: str, baudrate: int = BAUD, exclusive: bool = True, url: str = ""):
        super().__init__(url or path, baudrate)
        self.path = path
        self.exclusive = exclusive

    def _make_port(self) -> serial.Serial:
        remark = pi5_debug_uart_remark(self.path)
        if remark:
            raise TargetError(remark)
        if not os.path.exists(self.path):
            raise TargetError(self._missing())
        settings = self.port_settings()
        settings["baudrate"] = self.baudrate
        port = serial.Serial(None, exclusive=self.exclusive, **settings)
        port.port = self.path
        return port

    def _missing(self) -> str:
        from serial.tools import list_ports
        seen = sorted(p.device for p in list_ports.comports())
        msg = f"no such device: {self.path}."
        if self.path in ("/dev/serial0", "/dev/serial1"):
            msg += (" On a Raspberry Pi the header UART appears as /dev/serial0 only with 'enable_uart=1' "
                    "in config.txt (and the serial console disabled in raspi-config).")
        msg += " Serial ports on this machine: " + (", ".join(seen) if seen else "none found") + "."
        return msg

    def _explain(self, exc: BaseException) -> str:
        code = getattr(exc, "errno", None)
        text = str(exc)
        if code == errno.EACCES or code == errno.EPERM or "Permission denied" in text:
            return (f"permission denied opening {self.path}: your user may not use serial ports. Add it to "
                    "the 'dialout' group with 'sudo usermod -aG dialout $USER', then log out and in "
                    f"again (or run 'newgrp dialout'). ({text})")
        if "exclusively lock" in text or code == errno.EBUSY:
            holders = port_holders(self.path)
            who = ("held by " + ", ".join(holders)) if holders else "another program holds it"
            return (f"{self.path} is busy: another process has it open ({who}). Close the other program "
                    "(a terminal such as minicom or screen, another test run, a serial console), then "
                    "retry. "
                    f"({text})")
        if code == errno.ENOENT:
            return self._missing()
        if code == errno.EISDIR:
            return f"{self.path} is a directory, not a serial device."
        if "Could not configure port" in text or code == errno.ENOTTY:
            return f"{self.path} is not a serial port (it does not accept terminal settings): {text}"
        return f"cannot open serial port {self.path}: {text}"

    def diagnose(self, problem: str) -> str:
        if problem == "silent":
            return ("Is the Build HAT powered from its own supply (the barrel jack, 7.5-8.5 V)? Is it "
                    "still starting, or sitting in its bootloader after a reset (then it needs its "
                    "firmware loaded, e.g. by the buildhat Python library once)? Is this the right port: "
                    "the HAT is on the GPIO-header UART (/dev/serial0 on a Pi 4 with enable_uart=1, "
                    "/dev/ttyAMA0 on a Pi 5), and the Linux serial console must be disabled on it?")
        if problem == "garbage":
            return (f"Wrong baud rate? The Build HAT speaks {BAUD} 8N1; this port was opened at "
                    f"{self.baudrate}. Otherwise another device is on this port.")
        return ""


def from_url(url: str, **options) -> SerialTarget:
    """``/dev/...`` or any existing path, or ``serial:///dev/...?baud=N&exclusive=0``; both take
    ``reset=gpio[&chip=/dev/gpiochipN&reset_line=4&boot0_line=22]`` (a HAT on a Raspberry Pi's
    header: reset through its GPIO lines, harness/targets/gpio_reset.py)."""
    baud, exclusive, path = options.pop("baud", BAUD), options.pop("exclusive", True), url
    request_lines = options.pop("request_lines", None)      # tests: a fake GPIO chip
    query = ""
    if url.startswith("serial:"):
        parts = urlsplit(url)
        path, query = unquote(parts.path), parts.query
        if not path:
            raise TargetError(f"{url}: give the device path, e.g. serial:///dev/ttyAMA0?baud=115200")
    elif "?" in url and not os.path.exists(url):
        path, _, query = url.partition("?")
    gpio = {}
    for key, vals in parse_qs(query).items():
        if key == "baud":
            baud = vals[-1]
        elif key == "exclusive":
            exclusive = vals[-1] not in ("0", "false", "no")
        elif key in GPIO_OPTIONS:
            gpio[key] = vals[-1]
        else:
            raise TargetError(f"{url}: unknown option {key!r} (known: baud, exclusive, reset, chip, "
                              "reset_line, boot0_line)")
    try:
        baud = int(baud)
    except ValueError:
        raise TargetError(f"{url}: baud must be a number, got {baud!r}") from None
    if options:
        raise TargetError(f"{url}: options not understood by a serial port: {', '.join(sorted(options))}")
    target = SerialTarget(path, baudrate=baud, exclusive=exclusive, url=url)
    target.control = gpio_reset_from_options(gpio, url, request_lines=request_lines)
    return target
