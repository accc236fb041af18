"""pytest plugin for tests of the suite: at collection, write {nodeid: [requirement IDs]} as
JSON to $CONFORMANCE_IDS_OUT (used with --collect-only)."""
from __future__ import annotations

import json
import os


def pytest_collection_finish(session) -> None:
    out = {}
    for item in session.items:
        ids = []
        for mark in item.iter_markers("req"):
            ids.extend(str(a) for a in mark.args)
        out[item.nodeid] = ids
    with open(os.environ["CONFORMANCE_IDS_OUT"], "w", encoding="utf-8") as fh:
        json.dump(out, fh)
