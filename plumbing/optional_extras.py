"""How to install an optional extra, in words that work wherever this package came from.

The package is installed from a checkout (``pip install -e .``) or from a built wheel, not from
an index under its name, so a hint that names the package with an extra would fetch nothing of
ours. The hint names the extra's own packages, read from this installation's metadata, and the
checkout form.
"""
from __future__ import annotations

import shlex
from importlib import metadata
from typing import List

__all__ = ["extra_packages", "install_hint"]

_DIST = "buildhat-conformance"


def extra_packages(extra: str) -> List[str]:
    """The requirements the installed distribution lists for ``extra`` (empty if unknown)."""
    try:
        requires = metadata.requires(_DIST) or []
    except metadata.PackageNotFoundError:
        return []
    marker = f'extra == "{extra}"'
    return [r.split(";", 1)[0].strip() for r in requires if ";" in r and marker in r.split(";", 1)[1]]


def install_hint(extra: str) -> str:
    """``pip install 'matplotlib>=3.5' (the plots extra; in a checkout: pip install -e '.[plots]')``."""
    packages = extra_packages(extra)
    checkout = f"pip install -e '.[{extra}]'"
    if not packages:
        return f"in a checkout: {checkout}"
    wanted = " ".join(shlex.quote(p) for p in packages)
    return f"pip install {wanted} (the {extra} extra; in a checkout: {checkout})"
