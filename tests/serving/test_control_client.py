"""The one control-channel client: token first, ``ok``/``error`` replies, @drive_events and
@device_frames as JSON, and errors that name the request. A scripted fake server stands in for the
emulator's channel."""
from __future__ import annotations

import socket
import threading
from typing import Callable, List, Optional

import pytest

from buildhat_conformance.serving.control_client import ControlClient, ControlError, ControlRefused


def serve(path: str, answer: Callable[[str], Optional[str]], seen: List[str]) -> threading.Thread:
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    listener.bind(path)
    listener.listen(1)

    def run() -> None:
        conn, _ = listener.accept()
        with conn, conn.makefile("rb") as lines:
            for raw in lines:
                line = raw.decode().strip()
                seen.append(line)
                reply = answer(line)
                if reply is None:
                    return                     # hang up without a reply
                conn.sendall(reply.encode() + b"\n")
        listener.close()

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread


def test_token_goes_first_and_values_come_back(tmp_path):
    seen: List[str] = []
    replies = {"@auth s3cret": "ok", "@time": "ok 1234", "@plug 1 0x30": "ok"}
    serve(str(tmp_path / "c.sock"), lambda line: replies.get(line, "error no such action"), seen)
    with ControlClient(str(tmp_path / "c.sock"), token="s3cret", timeout=5) as client:
        client.connect(wait=5)
        assert client.value("@time") == "1234"
        assert client.request("@plug 1 0x30") == "ok"
        with pytest.raises(ControlRefused, match=r"refused '@explode': no such action"):
            client.value("@explode")
    assert seen == ["@auth s3cret", "@time", "@plug 1 0x30", "@explode"]


def test_a_refused_token_says_so(tmp_path):
    serve(str(tmp_path / "c.sock"), lambda line: "error bad token", [])
    client = ControlClient(str(tmp_path / "c.sock"), token="wrong", timeout=5)
    with pytest.raises(ControlError, match="refused the token"):
        client.connect(wait=5)
    assert not client.connected


def test_drive_events_are_parsed_and_garbage_is_named(tmp_path):
    answers = iter(['ok [{"kind": "pwm", "port": 0, "value": 0.5, "t": 10}]', "ok not json"])
    serve(str(tmp_path / "c.sock"), lambda line: next(answers), [])
    with ControlClient(str(tmp_path / "c.sock"), timeout=5) as client:
        assert client.drive_events_since(3) == [{"kind": "pwm", "port": 0, "value": 0.5, "t": 10}]
        with pytest.raises(ControlError, match="unreadable @drive_events reply"):
            client.drive_events_since(3)


def test_device_frames_ask_from_when_and_garbage_is_named(tmp_path):
    seen: List[str] = []
    answers = iter(['ok [{"kind": "dev", "port": 1, "data": "4301bd", "t": 7}]', "ok {}"])
    serve(str(tmp_path / "c.sock"), lambda line: next(answers), seen)
    with ControlClient(str(tmp_path / "c.sock"), timeout=5) as client:
        assert client.device_frames_since(5) == [{"kind": "dev", "port": 1, "data": "4301bd", "t": 7}]
        with pytest.raises(ControlError, match="unreadable @device_frames reply"):
            client.device_frames_since(0)
    assert seen == ["@device_frames 5", "@device_frames 0"]


def test_a_closed_channel_names_the_request(tmp_path):
    serve(str(tmp_path / "c.sock"), lambda line: None, [])
    with ControlClient(str(tmp_path / "c.sock"), timeout=5) as client:
        with pytest.raises(ControlError, match=r"closed its control channel \(request '@settled'\)"):
            client.request("@settled")
        assert not client.connected


def test_no_emulator_is_one_clear_error(tmp_path):
    with pytest.raises(ControlError, match="cannot reach the emulator's control channel"):
        ControlClient(str(tmp_path / "absent.sock"), timeout=1).connect(wait=0)
