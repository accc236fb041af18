"""Per-test verdict: pass / fail / skip / known deviation / informational, and the two that
are not about the protocol: target-fault (the target misbehaved as a device: silent, dead,
restarted, garbled, not reading; conformance/target_fault.py) and not-run (the run stopped
talking to the target before the case).

A test states what the document requires and what this release is known to do instead;
:meth:`Verdict.document` turns that into the verdict. Failures go through ``pytest.fail``
so pytest's own outcome and exit status stay the single source of "did it fail".
"""
from __future__ import annotations

from typing import List, Optional, Tuple

import pytest

from .deviations import deviation

__all__ = ["Verdict", "UnknownBuild", "PASS", "FAIL", "SKIP", "KNOWN", "INFO", "TARGET_FAULT", "NOT_RUN",
           "VERDICTS"]

PASS, FAIL, SKIP, KNOWN, INFO = "pass", "fail", "skip", "known deviation", "informational"
TARGET_FAULT, NOT_RUN = "target-fault", "not-run"
#: Every verdict, in the order summaries show them.
VERDICTS = (PASS, FAIL, TARGET_FAULT, NOT_RUN, SKIP, KNOWN, INFO)


class UnknownBuild(Exception):
    """Raised by a check that needs a behaviour on which the two releases around an unknown
    build differ (``Hat.feature``): the case ends ``informational`` with this message, never
    ``fail`` (the plugin turns it into the verdict)."""


class Verdict:
    def __init__(self, profile_name: str, between: Optional[Tuple[str, str]] = None):
        """``between``: for an unknown build, the releases just before and after it (the
        ``profile_name`` is the earlier one, whose command table the build is driven with)."""
        self.profile_name = profile_name
        self.between = between
        self.known: List[Tuple[str, str]] = []      # (deviation key, what was seen)
        self.notes: List[str] = []
        self.informational = False

    def document(self, document_ok: bool, *, key: Optional[str] = None, firmware_ok: bool = False,
                 seen: str = "") -> None:
        """Judge one observation.

        ``document_ok``: the target did what the document says. ``key``: the deviation in
        deviations.json this check can show; ``firmware_ok``: the target did exactly what
        that deviation says the release does instead.
        """
        if document_ok:
            return
        if key is None:
            pytest.fail(f"deviates from the document: {seen}", pytrace=False)
        dev = deviation(key)
        if self.between is not None and dev.applies_to(self.between[0]) != dev.applies_to(self.between[1]):
            # An unknown build between a release with this deviation and one without it may
            # be either: what the deviating one does is no fault of this build
            # (docs/FIRMWARE-BEHAVIOUR.md describes the releases only). Anything else is neither
            # release's behaviour: a failure.
            had, fixed = self.between if dev.applies_to(self.between[0]) else self.between[::-1]
            if firmware_ok:
                self.inform(f"behaviour of {self.between[0]} or {self.between[1]}: unknown build; it does "
                            f"what {had} is known to do ({key}: {dev.firmware}) and {fixed} does not; "
                            f"seen: {seen}")
                return
            pytest.fail(f"{key}: the document requires: {dev.document}; this unknown build does neither "
                        f"that nor what {had} does instead ({dev.firmware}); seen: {seen}", pytrace=False)
        if dev.applies_to(self.profile_name) and firmware_ok:
            self.known.append((key, seen))
            return
        if dev.applies_to(self.profile_name):
            pytest.fail(f"{key}: neither the document ({dev.document}) nor the known behaviour of "
                        f"{self.profile_name} ({dev.firmware}); seen: {seen}", pytrace=False)
        pytest.fail(f"{key}: the document requires: {dev.document}; {self.profile_name} is not known to "
                    f"deviate here ({dev.reference}); seen: {seen}", pytrace=False)

    def inform(self, note: str) -> None:
        """Mark the case informational: it measured something the document does not bound."""
        self.informational = True
        self.notes.append(note)

    def note(self, text: str) -> None:
        self.notes.append(text)

    @property
    def verdict_class(self) -> str:
        if self.known:
            return KNOWN
        if self.informational:
            return INFO
        return PASS
