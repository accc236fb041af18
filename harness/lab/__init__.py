"""A lab of HATs on labgrid: places acquired through a labgrid coordinator (docs/LAB.md).

labgrid is the lab manager (places, locks, exporters, ser2net); this package only uses it:

- :mod:`.client`: one connection to the coordinator (labgrid's own client session): places,
  acquire, release, a place's resources;
- :mod:`.lease`: holding a place for one run (this machine's lock file beside labgrid's lock:
  a place left acquired by a killed run is taken back, a live run's is not);
- :mod:`.outputs`: the place's ``reset``/``boot0`` digital outputs as a :class:`Control`;
- :mod:`.selection`: ``--places`` (a place-name pattern or a ``key=value`` tag).

labgrid is optional (the ``lab`` extra); :func:`need_labgrid` says in one line what to install.
"""
from __future__ import annotations

import os

from ...plumbing.optional_extras import install_hint
from ..targets.base import TargetError

__all__ = ["need_labgrid", "coordinator_address", "DEFAULT_COORDINATOR"]

#: labgrid's own default (labgrid-client, labgrid-exporter)
DEFAULT_COORDINATOR = "127.0.0.1:20408"


def need_labgrid() -> None:
    """Raise TargetError (one line) when labgrid is not installed."""
    try:
        import labgrid  # noqa: F401 - only to say now, in one line, that it is missing
    except ImportError:
        raise TargetError(f"a labgrid place needs labgrid: {install_hint('lab')}") from None


def coordinator_address(given: str = "") -> str:
    """``?coordinator=``, else ``LG_COORDINATOR``, else labgrid's default."""
    return given or os.environ.get("LG_COORDINATOR") or DEFAULT_COORDINATOR
