"""examples/github-actions-host-library.yml is run, not just read: its emulator command lines must parse,
and its python-library job's own shell steps (start, lint gate, stop) must pass a real library session
and fail a wrong host. Paths under /tmp are moved into a private directory."""
from __future__ import annotations

import os
import pathlib
import re
import shlex
import socket
import subprocess
import sys
import time
from typing import Dict, List

import pytest
import serial
import workflow_steps  # noqa: E402
from hostlib.scenario import run_scenario  # noqa: E402
from hostlib.venvs import buildhat_python  # noqa: E402
from repo_paths import REPO  # noqa: E402

from buildhat_conformance.emulator.cli import build_parser

WORKFLOW = REPO / "examples" / "github-actions-host-library.yml"
pytestmark = pytest.mark.timeout(180)


def job_steps(job: str) -> Dict[str, str]:
    return workflow_steps.job_steps(WORKFLOW, job)


def matrix_entries() -> List[Dict[str, str]]:
    text = WORKFLOW.read_text()
    return [{"firmware": fw, "bootloader": bl} for fw, bl in
            re.findall(r'- firmware: "(\d+)"\s+bootloader: "([^"]*)"', text)]


def emulator_commands() -> List[List[str]]:
    joined = WORKFLOW.read_text().replace("\\\n", " ")
    out = []
    for entry in matrix_entries():
        text = joined.replace("${{ matrix.firmware }}", entry["firmware"])
        text = text.replace("${{ matrix.bootloader }}", entry["bootloader"])
        for line in text.splitlines():
            if line.strip().startswith("buildhat-emulator "):
                words = shlex.split(line.split(">")[0])
                out.append(words[1:])
    return out


def test_every_emulator_command_in_the_workflow_parses() -> None:
    commands = emulator_commands()
    assert len(commands) >= 3, commands            # two matrix entries + the TCP job
    for args in commands:
        parsed = build_parser().parse_args(args)
        assert parsed.strict_host, args              # the example always gates on the lint


def run_step(script: str, tmp: pathlib.Path, timeout: float = 60) -> subprocess.CompletedProcess:
    env = dict(os.environ, PATH=f"{pathlib.Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}")
    return subprocess.run(["bash", "-euo", "pipefail", "-c", script.replace("/tmp/", f"{tmp}/")],
                          env=env, capture_output=True, text=True, timeout=timeout)


@pytest.mark.network
def test_python_library_job_gates_on_the_lint(tmp_path: pathlib.Path) -> None:
    python = buildhat_python("0.5.7")       # from PyPI: a failed install fails (the test is marked)
    steps = job_steps("python-library")
    entry = [e for e in matrix_entries() if e["firmware"] == "1636109636"][0]   # no upload: fast
    start = steps["Start the emulator"].replace("${{ matrix.firmware }}", entry["firmware"])
    start = start.replace("${{ matrix.bootloader }}", entry["bootloader"])
    gate, stop = steps["Fail on host-lint findings"], steps["Stop the emulator and show its report"]
    started = run_step(start, tmp_path)
    assert started.returncode == 0, started.stderr
    try:
        # The library under test: the real buildhat 0.5.7 on the workflow's pty.
        result = run_scenario(python, "hat.py", str(tmp_path / "buildhat"), str(tmp_path / "buildhat.ctl"),
                              {}, timeout=40)
        assert result.values.get("finished") and result.values["firmware"].startswith("1636109636"), \
            result.explain()
        passed = run_step(gate, tmp_path)
        assert passed.returncode == 0 and '"clean": true' in passed.stdout, passed.stdout + passed.stderr
        # A wrong host (CRLF endings) on the same emulator: --strict-host ends it, the gate fails.
        with serial.Serial(str(tmp_path / "buildhat"), 115200, timeout=0.2) as port:
            port.write(b"version\r\nvin\r")
            time.sleep(0.5)
        failed = run_step(gate, tmp_path)
        assert failed.returncode != 0, failed.stdout
    finally:
        stopped = run_step(stop, tmp_path)
    assert "--strict-host" in stopped.stdout and "crlf" in stopped.stdout, stopped.stdout


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def test_other_language_job_on_tcp_gates_on_the_lint(tmp_path: pathlib.Path) -> None:
    steps = job_steps("other-language")
    data_port, control_port = free_port(), free_port()

    def local(script: str) -> str:   # our own ports; the emulator is installed already
        script = script.replace("127.0.0.1:4000", f"127.0.0.1:{data_port}")
        script = script.replace("4001", str(control_port))
        return "\n".join(line for line in script.splitlines() if "pip install" not in line) + "\n"

    start = local(steps["Install and start the emulator on TCP"])
    gate = local(steps["Fail on host-lint findings"])
    stop = local(steps["Stop the emulator and show its report"])
    assert run_step(start, tmp_path).returncode == 0
    try:
        with socket.create_connection(("127.0.0.1", data_port), timeout=5) as host:   # a correct host
            host.sendall(b"version\r")
            reply = b""
            while b"Firmware version: 1737564117" not in reply:
                reply += host.recv(4096)
            passed = run_step(gate, tmp_path)
            assert passed.returncode == 0 and '"clean": true' in passed.stdout, passed.stdout + passed.stderr
            host.sendall(b"port 0 ; bias 0.3\r")                                    # now a wrong one
            time.sleep(0.5)
        failed = run_step(gate, tmp_path)
        assert failed.returncode != 0, failed.stdout
    finally:
        stopped = run_step(stop, tmp_path)
    assert "--strict-host" in stopped.stdout and "'bias'" in stopped.stdout, stopped.stdout
