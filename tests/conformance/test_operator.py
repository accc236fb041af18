"""``--operator`` (conformance/operator_prompt.py): the person at the bench is shown the instruction, Enter
means
done, `s` means skip, and pytest's output capture is set aside while asking (else the prompt is unseen)."""
from __future__ import annotations

import contextlib
from types import SimpleNamespace

import pytest

from buildhat_conformance.conformance.operator_prompt import ask


class _Capture:
    def __init__(self) -> None:
        self.suspended = False
        self.seen_suspended = False

    @contextlib.contextmanager
    def global_and_fixture_disabled(self):
        self.suspended = True
        try:
            yield
        finally:
            self.suspended = False


def _config(capture):
    return SimpleNamespace(pluginmanager=SimpleNamespace(getplugin=lambda name: capture))


@pytest.mark.parametrize("typed,done", [("", True), ("  \n", True), ("s", False), (" S ", False),
                                        ("ok", True)])
def test_enter_is_done_and_s_is_skip(monkeypatch, typed, done):
    capture = _Capture()
    prompts = []

    def fake_input(prompt: str) -> str:
        prompts.append(prompt)
        capture.seen_suspended = capture.suspended
        return typed

    monkeypatch.setattr("builtins.input", fake_input)
    assert ask(_config(capture), "plug a SPIKE motor into port 1") is done
    assert "[operator] plug a SPIKE motor into port 1" in prompts[0] and capture.seen_suspended


def test_without_a_capture_manager_it_still_asks(monkeypatch):
    monkeypatch.setattr("builtins.input", lambda prompt: "s")
    assert ask(_config(None), "unplug port 0") is False
