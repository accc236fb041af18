"""``buildhat-conformance mock``: its command line (the fake HAT and its servers are transcripts/mock.py)."""
from __future__ import annotations

import argparse
import signal
import threading

from ..plumbing.cli_options import SPEED_HELP, UsageError
from .mock_serve import serve_pty, serve_tcp

__all__ = ["add_arguments", "main"]


# -- command line ------------------------------------------------------------------------
def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("transcript", metavar="FILE", help="transcript (.jsonl) to serve")
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--pty", action="store_true", help="serve on a pseudo-terminal (default); "
                      "the first stdout line is its path")
    mode.add_argument("--tcp", metavar="[HOST:]PORT", help="serve on a TCP port (pyserial socket://)")
    parser.add_argument("--link", metavar="PATH", help="with --pty: also make this symlink to the device")
    parser.add_argument("--speed", type=float, metavar="N",
                        help=f"{SPEED_HELP}: the recorded delays (HAT time) play N times faster than real "
                             "time (default: the recording's time_scale, so the host sees the pace it saw)")
    parser.add_argument("--strict", action="store_true",
                        help="stop with exit status 1 at the first host line that departs from the recording")
    parser.add_argument("--once", action="store_true", help="with --tcp: exit after the first client leaves")


def main(args: argparse.Namespace) -> int:
    from .transcript_check import load_transcript

    transcript = load_transcript(args.transcript)
    stop = threading.Event()

    def on_signal(_sig, _frame) -> None:
        stop.set()

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    if args.tcp:
        host, _, port = args.tcp.rpartition(":")
        try:
            port_no = int(port)
        except ValueError:
            raise UsageError(f"--tcp wants [HOST:]PORT, got {args.tcp!r}") from None
        return serve_tcp(transcript, host or "127.0.0.1", port_no, args.speed, args.strict, args.once, stop)
    return serve_pty(transcript, args.link, args.speed, args.strict, stop)
