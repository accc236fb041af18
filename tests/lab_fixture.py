"""A labgrid lab on loopback for tests: a real labgrid-coordinator and labgrid-exporter, emulators
as the HATs of its places.

Each place is one ``buildhat-emulator --pty`` (its own control socket): the exporter exports the
pty as a ``RawSerialPort`` (so labgrid runs ser2net for it, RFC 2217 on a free TCP port) and an
``HttpDigitalOutput`` named ``reset`` served here, whose PUT drives that emulator's RESET pin
(``@gpio reset 0|1``), as a Pi's GPIO drives a real HAT's. Places are made with labgrid-client
(create, add-match, set-tags ``board=buildhat``), as docs/LAB.md says a lab owner does.
"""
from __future__ import annotations

import http.server
import os
import pathlib
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from typing import Dict, List, Optional

BIN = pathlib.Path(sys.executable).parent


def missing() -> Optional[str]:
    """Why a lab cannot run here, or None."""
    if not (BIN / "labgrid-coordinator").exists():
        return "labgrid is not installed (the lab extra: pip install -e '.[lab]')"
    if not (shutil.which("ser2net") or os.path.exists("/usr/sbin/ser2net")):
        return "ser2net is not installed (Debian: apt-get install ser2net; .ci/run does it)"
    return None


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def control(sock_path: str, line: str) -> str:
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
        s.connect(sock_path)
        s.sendall(line.encode() + b"\n")
        return s.makefile("rb").readline().decode().strip()


class _Outputs(http.server.ThreadingHTTPServer):
    daemon_threads = True
    controls: Dict[str, str] = {}
    levels: Dict[str, str] = {}
    log: List[str] = []


class _Handler(http.server.BaseHTTPRequestHandler):
    server: _Outputs

    def do_PUT(self) -> None:       # noqa: N802 - http.server's name
        place, _, pin = self.path.strip("/").partition("/")
        body = self.rfile.read(int(self.headers.get("Content-Length") or 0)).decode().strip()
        reply = control(self.server.controls[place], f"@gpio {pin} {body}")
        self.server.levels[self.path] = body
        self.server.log.append(f"{place} {pin} {body}")
        self.send_response(200 if reply == "ok" else 500)
        self.end_headers()

    def do_GET(self) -> None:       # noqa: N802
        data = self.server.levels.get(self.path, "1").encode()
        self.send_response(200)
        self.end_headers()
        self.wfile.write(data)

    def log_message(self, *_args: object) -> None:
        pass


class Lab:
    """``places``: name -> emulator argv extras. Start with :meth:`start`, end with :meth:`stop`."""

    def __init__(self, root: pathlib.Path, places: Dict[str, List[str]]):
        self.root, self.spec = root, places
        self.procs: List[subprocess.Popen] = []
        self.address = f"127.0.0.1:{free_port()}"
        self.env = dict(os.environ, LG_COORDINATOR=self.address, XDG_CACHE_HOME=str(root / "cache"))
        self.outputs = _Outputs(("127.0.0.1", 0), _Handler)
        self.outputs.controls, self.outputs.levels, self.outputs.log = {}, {}, []

    def _spawn(self, argv: List[str], log: str, **kw) -> subprocess.Popen:
        out = open(self.root / log, "w")
        proc = subprocess.Popen(argv, stdout=out, stderr=subprocess.STDOUT, env=self.env,
                                start_new_session=True, **kw)
        self.procs.append(proc)
        return proc

    def client(self, *args: str, check: bool = True) -> subprocess.CompletedProcess:
        return subprocess.run([str(BIN / "labgrid-client"), "-x", self.address, *args], env=self.env,
                              capture_output=True, text=True, timeout=60, check=check)

    def start(self) -> Lab:
        threading.Thread(target=self.outputs.serve_forever, daemon=True).start()
        url = f"http://127.0.0.1:{self.outputs.server_address[1]}"
        config = []
        for name, extra in self.spec.items():
            sock = str(self.root / f"{name}.ctl")
            emu = subprocess.Popen([str(BIN / "buildhat-emulator"), "--pty", "--control", sock, *extra],
                                   stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                                   start_new_session=True)
            self.procs.append(emu)
            assert emu.stdout is not None
            pty = emu.stdout.readline().strip()
            assert pty.startswith("/dev/"), pty
            self.outputs.controls[name] = sock
            config.append(f"{name}:\n  serial:\n    cls: RawSerialPort\n    port: {pty}\n    speed: 115200\n"
                          f"  reset:\n    cls: HttpDigitalOutput\n    url: {url}/{name}/reset\n"
                          f"    body_asserted: '1'\n    body_deasserted: '0'\n")
        (self.root / "exporter.yaml").write_text("".join(config))
        (self.root / "coordinator").mkdir()
        self._spawn([str(BIN / "labgrid-coordinator"), "--listen", self.address], "coordinator.log",
                    cwd=self.root / "coordinator")
        self._wait(lambda: self.client("places", check=False).returncode == 0, "the coordinator")
        self._spawn([str(BIN / "labgrid-exporter"), "-c", self.address, "--hostname", "127.0.0.1",
                     "-n", "exp",
                     str(self.root / "exporter.yaml")], "exporter.log")
        for name in self.spec:
            self.client("-p", name, "create")
            self.client("-p", name, "add-match", f"exp/{name}/*")
            self.client("-p", name, "set-tags", "board=buildhat")
        want = {f"exp/{name}/{cls}" for name in self.spec
                for cls in ("NetworkSerialPort", "HttpDigitalOutput")}
        self._wait(lambda: want <= set(self.client("resources").stdout.split()), "the exporter's resources")
        return self

    def _wait(self, ready, what: str, timeout: float = 60.0) -> None:
        end = time.monotonic() + timeout
        while not ready():
            if time.monotonic() > end:
                raise AssertionError(f"{what} did not come up; logs in {self.root}")
            time.sleep(0.3)

    def holder(self, place: str) -> str:
        """labgrid-client's word on who holds ``place`` ("" when free)."""
        for line in self.client("-p", place, "show").stdout.splitlines():
            if line.strip().startswith("acquired:"):
                value = line.split(":", 1)[1].strip()
                return "" if value == "None" else value
        return ""

    def stop(self) -> None:
        self.outputs.shutdown()
        for proc in reversed(self.procs):
            if proc.poll() is None:
                try:
                    os.killpg(proc.pid, signal.SIGTERM)     # the exporter's ser2net children too
                except ProcessLookupError:
                    pass
        for proc in self.procs:
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
