"""A HAT in a labgrid lab: ``labgrid:PLACE[?coordinator=HOST:PORT&wait=S&reset_output=NAME&...]``
(also ``boot0_output=NAME``, ``serial=NAME``).

Opening acquires the place through the coordinator (``?coordinator=``, else ``LG_COORDINATOR``)
for the run's whole life, or uses it when this user holds it already (harness/lab/lease.py);
closing releases it, and so do exit, Ctrl-C and SIGTERM. The bytes go through the place's
network serial port (``NetworkSerialPort``: ser2net on the exporter, RFC 2217 or raw TCP); reset
and BOOT0 are the place's digital outputs named ``reset``/``boot0`` (harness/lab/outputs.py),
so recovery and firmware load work on a remote HAT as on a local one. docs/LAB.md sets a lab up.
"""
from __future__ import annotations

from typing import Any, Optional
from urllib.parse import parse_qs, unquote, urlsplit

from .base import Target, TargetError
from .pyserial_url import PyserialUrlTarget

__all__ = ["LabgridTarget", "from_url", "OPTIONS"]

OPTIONS = ("coordinator", "wait", "reset_output", "boot0_output", "serial")


class LabgridTarget(Target):
    reset_hint = "give the labgrid place a digital output named reset (docs/LAB.md)"

    def __init__(self, url: str, place: str, coordinator: str = "", wait: float = 0.0,
                 reset_output: str = "", boot0_output: str = "", serial: str = ""):
        self.url, self.place, self.coordinator, self.wait = url, place, coordinator, wait
        self.reset_output, self.boot0_output, self.serial_name = reset_output, boot0_output, serial
        self.inner: Optional[PyserialUrlTarget] = None
        self.lease: Any = None
        self.serial_url = ""

    def open(self) -> None:
        if self.is_open:
            return
        from ..lab.client import client_for
        from ..lab.lease import PlaceLease

        client = client_for(self.coordinator)
        self.coordinator = client.address
        lease = PlaceLease(client, self.place, wait=self.wait)
        lease.take()
        try:
            lg_target = client.labgrid_target(self.place)
            self.serial_url = self._serial_url(lg_target)
            self.control = self._outputs(lg_target)
            inner = PyserialUrlTarget(self.serial_url)
            inner.open()
        except BaseException:
            lease.give_back()
            raise
        self.inner, self.lease, self.is_open = inner, lease, True

    def _serial_url(self, lg_target: Any) -> str:
        from labgrid.util.proxy import proxymanager

        ports = [r for r in lg_target.resources if type(r).__name__ == "NetworkSerialPort"]
        if self.serial_name:
            ports = [r for r in ports if r.name == self.serial_name]
        if len(ports) != 1:
            what = f"{len(ports) or 'no'} network serial ports"
            if self.serial_name:
                what += f" named {self.serial_name!r}"
            raise TargetError(f"labgrid place {self.place} has {what}: it needs one, the HAT's UART "
                              "exported through ser2net (RawSerialPort or USBSerialPort on its exporter; "
                              "several: ?serial=NAME; docs/LAB.md)")
        port = ports[0]
        host, tcp = proxymanager.get_host_and_port(port)
        if port.protocol == "raw":
            return f"socket://{host}:{tcp}"
        # ser2net's RFC 2217 server does not answer the modem-control option; labgrid's pyserial
        # (pyserial-labgrid) can skip it, plain pyserial waits for it and gives up
        _need_labgrids_pyserial()
        return f"rfc2217://{host}:{tcp}?ign_set_control"

    def _outputs(self, lg_target: Any) -> Any:
        from ..lab.outputs import DEFAULT_BOOT0, DEFAULT_RESET, outputs_of

        return outputs_of(lg_target, self.place, self.reset_output or DEFAULT_RESET,
                          self.boot0_output or DEFAULT_BOOT0, required=bool(self.reset_output))

    def write(self, data: bytes) -> None:
        self._require().write(data)

    def read(self, timeout: float) -> bytes:
        return self._require().read(timeout)

    def close(self) -> None:
        inner, self.inner = self.inner, None
        lease, self.lease = self.lease, None
        self.is_open = False
        try:
            if inner is not None:
                inner.close()
        finally:
            if lease is not None:
                lease.give_back()

    def _require(self) -> PyserialUrlTarget:
        if self.inner is None:
            raise TargetError(f"{self.url} is not open")
        return self.inner

    def diagnose(self, problem: str) -> str:
        where = f" (the place's serial port is {self.serial_url})" if self.serial_url else ""
        if problem == "silent":
            return ("The place's serial port connects but nothing answers: is the HAT of place "
                    f"{self.place} powered, and does its exporter export the HAT's UART at 115200?{where}")
        if problem == "garbage":
            return f"Check the baud rate the place's exporter gives its serial port (115200){where}."
        return ""


def _need_labgrids_pyserial() -> None:
    import serial.rfc2217

    with open(serial.rfc2217.__file__, encoding="utf-8") as fh:
        if "ign_set_control" in fh.read():
            return
    raise TargetError("the installed pyserial is not labgrid's (it cannot talk to ser2net's RFC 2217 port): "
                      "pip install --force-reinstall --no-deps pyserial-labgrid")


def from_url(url: str, **options: Any) -> LabgridTarget:
    parts = urlsplit(url)
    place = unquote(parts.path).strip("/")
    if not place:
        raise TargetError(f"{url}: name the place, e.g. labgrid:hat-1 "
                          "(buildhat-conformance targets lists them)")
    values = {}
    for key, vals in parse_qs(parts.query).items():
        if key not in OPTIONS:
            raise TargetError(f"{url}: unknown option {key!r} (known: {', '.join(OPTIONS)})")
        values[key] = vals[-1]
    if options:
        raise TargetError(f"{url}: options not understood by a labgrid place: {', '.join(sorted(options))}")
    try:
        wait = float(values.pop("wait", "0"))
    except ValueError:
        raise TargetError(f"{url}: wait must be a number of seconds") from None
    from ..lab import need_labgrid

    need_labgrid()
    return LabgridTarget(url, place, wait=wait, **values)
