"""``buildhat-conformance sil``: one command for the firmware on this host. Its own actions (build,
serve, coverage) are sil/cli.py's; the campaigns that run the suite on many builds (mutate, bisect,
history and their merges) are campaigns/cli.py's, a floor above the suite: only the root may name both.
"""
# The folders install under this package's name (setup.py); pyright reads the checkout, where they
# sit beside this folder.
# pyright: reportMissingImports=false
from __future__ import annotations

import argparse

from .campaigns import cli as campaigns_cli
from .sil import cli as sil_cli

__all__ = ["add_arguments", "main"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sil_cli.add_arguments(parser, more=campaigns_cli.add_actions)


def main(args: argparse.Namespace) -> int:
    if args.sil_command in campaigns_cli.ACTIONS:
        return campaigns_cli.main(args)
    return sil_cli.main(args)
