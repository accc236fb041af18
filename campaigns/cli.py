"""The campaigns' actions of ``buildhat-conformance sil`` (buildhat_conformance/cli_sil.py puts them
beside sil/cli.py's): ``sil mutate`` (``--shard K/N``), ``sil mutate-merge``, ``sil bisect``,
``sil history`` (``--shard``) and ``sil history-merge``: docs/COMPARING-BUILDS.md and the modules they
call. Each action's ``--help`` ends with its own exit statuses (plumbing/cli_exits.py).
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from ..plumbing.cli_exits import exit_status_help
from ..plumbing.cli_options import UsageError
from ..sil.build import BuildError, find_tree
from .mutants import DEFAULT_FILES, KINDS

__all__ = ["ACTIONS", "add_actions", "main"]

#: The ``sil`` actions this module runs.
ACTIONS = ("mutate", "mutate-merge", "bisect", "history", "history-merge")


def add_actions(sub) -> None:  # type: ignore[no-untyped-def]
    """Add the campaigns' actions to ``sil``'s sub-parsers."""
    mut = sub.add_parser("mutate", help="plant single-site changes in a tree and run the suite on each",
                         description="Seeded single-site mutants of a firmware tree, each built and run "
                                     "against the suite in virtual time: killed, survived, "
                                     "likely equivalent.",
                         epilog=exit_status_help("sil mutate"))
    mut.add_argument("tree", metavar="TREE", help="a firmware-pico/ folder, or a checkout containing one")
    mut.add_argument("--files", default=",".join(DEFAULT_FILES), metavar="LIST",
                     help="the C files to mutate, comma-separated (default: %(default)s)")
    mut.add_argument("--kinds", default=",".join(KINDS), metavar="LIST", help="mutation kinds (default: all)")
    mut.add_argument("--count", type=int, default=20, metavar="N", help="how many mutants (default 20)")
    mut.add_argument("--seed", type=int, default=1, metavar="N", help="which mutants (default 1)")
    mut.add_argument("--jobs", type=int, default=2, metavar="N", help="mutants at once (default 2)")
    mut.add_argument("-k", dest="keyword", default=None, metavar="EXPR",
                     help="only the suite's cases matching EXPR")
    mut.add_argument("--all-cases", action="store_true",
                     help="run every case on a killed mutant too (default: its run stops at the first "
                          "failing case, which is all the verdict needs)")
    mut.add_argument("--killers-first", default=None, metavar="JSON",
                     help="run first, in every run of the campaign, the cases that killed mutants in an "
                          "earlier campaign (its mutation.json; default: the one in --output, if any; "
                          "'none': the suite's own order)")
    mut.add_argument("--plant", action="append", default=[], metavar="FILE:OLD:NEW",
                     help="also run this hand-made mutant (the first OLD in FILE becomes NEW)")
    mut.add_argument("--shard", default=None, metavar="K/N",
                     help="run only the K-th of N parts of the campaign (every N-th mutant of the draw); "
                          "sil mutate-merge makes one page and JSON of the parts")
    mut.add_argument("-o", "--output", default=os.path.join("reports", "mutation"), metavar="DIR",
                     help="where the page, the JSON and survivors' transcripts go (default %(default)s)")
    _add_bisect(sub)
    _add_mutate_merge(sub)
    _add_history(sub)


def main(args: argparse.Namespace) -> int:
    if args.sil_command == "mutate":
        return _mutate(args)
    if args.sil_command == "bisect":
        return _bisect(args)
    if args.sil_command == "mutate-merge":
        return _mutate_merge(args)
    return _history(args)


def _mutate(args: argparse.Namespace) -> int:
    from .first_failure_plugin import killers as case_killers
    from .mutants import find_mutants, planted, sample
    from .mutation import run_campaign
    from .mutation_report import write_reports
    try:
        tree = find_tree(args.tree)
    except BuildError as exc:
        raise UsageError(str(exc)) from None
    kinds = [k for k in args.kinds.split(",") if k]
    bad = [k for k in kinds if k not in KINDS]
    if bad or args.count < 0 or args.jobs < 1:
        raise UsageError(f"unknown mutation kind {bad[0]!r} (known: {', '.join(KINDS)})" if bad
                         else "--count takes 0 or more, --jobs 1 or more")
    files = [f for f in args.files.split(",") if f]
    missing = [f for f in files if not (tree / f).is_file()]
    if missing:
        raise UsageError(f"{missing[0]}: not a file of {tree}")
    chosen = sample(find_mutants(tree, files, kinds), args.count, args.seed)
    texts: dict = {}

    def changed(m) -> str:
        """The mutant's file as it builds it: two mutants that make the same one would share a
        build folder, which the first to finish removes under the other (--jobs 2)."""
        if m.file not in texts:
            texts[m.file] = (tree / m.file).read_text(encoding="utf-8", errors="replace")
        return m.apply(texts[m.file])

    for spec in args.plant:
        parts = spec.split(":", 2)
        hand = planted(tree, *parts) if len(parts) == 3 else None
        if hand is None:
            raise UsageError(f"--plant {spec!r}: give FILE:OLD:NEW with OLD found in FILE")
        twin = next((m for m in chosen if m.file == hand.file and changed(m) == changed(hand)), None)
        if twin is not None:
            raise UsageError(f"--plant {spec!r}: makes the same {hand.file} as {twin.describe()}, "
                             "which already runs")
        chosen.append(hand)
    if not chosen:
        raise UsageError("no mutants to run (--count 0 and no --plant)")
    indices = None
    if args.shard is not None:
        from .shards import parse_shard, shard_of
        try:
            k, n = parse_shard(args.shard)
        except ValueError as exc:
            raise UsageError(str(exc)) from None
        indices, chosen = shard_of(chosen, k, n)
        if not chosen:
            raise UsageError(f"--shard {args.shard}: this part has no mutants (the campaign has "
                             f"{n - 1 if k > 1 else 0} or fewer); use fewer parts")
    out = Path(args.output)
    earlier = Path(args.killers_first) if args.killers_first not in (None, "none") else out / "mutation.json"
    killers: list = []
    if args.killers_first != "none" and (args.killers_first is not None or earlier.is_file()):
        try:
            killers = case_killers(earlier)
        except (OSError, ValueError) as exc:
            raise UsageError(f"--killers-first {earlier}: not an earlier campaign's mutation.json ({exc})") \
                from None

    def progress(o, i, n) -> None:
        said = ("  (every case passed: survived or likely equivalent is judged after the control runs)"
                if o.status == "pending" else
                f"  <- {o.verdict_text()}" if o.cases else (f"  ({o.detail})" if o.detail else ""))
        print(f"[{i}/{n}] {o.status:<17} {o.mutant.describe()}{said}", flush=True)

    print(f"sil mutate: {len(chosen)} mutants of {tree} (seed {args.seed}"
          + (f", part {args.shard}" if args.shard else "") + "); reference run first"
          + (f"; the {len(killers)} cases that killed mutants in {earlier} run first" if killers else ""),
          flush=True)
    try:
        campaign = run_campaign(str(tree), chosen, out / "work", jobs=args.jobs, keyword=args.keyword,
                                progress=progress, stop_at_first=not args.all_cases, killers_first=killers)
    except (BuildError, RuntimeError) as exc:
        print(f"buildhat-conformance sil: {exc}", file=sys.stderr)
        return 3
    campaign.seed, campaign.shard, campaign.indices = args.seed, args.shard or "", indices
    page = write_reports(campaign, out)
    print(campaign.summary_line())
    print(f"report: {page}  json: {out / 'mutation.json'}")
    return 0


def _add_repository_options(parser: argparse.ArgumentParser, last: str) -> None:
    """What `sil bisect` and `sil history` share: the checkout, the tree's folder in it, the cases."""
    parser.add_argument("-C", dest="repo", default=".", metavar="REPO",
                        help="the repository's checkout (default: the current folder)")
    parser.add_argument("--folder", default=None, metavar="PATH",
                        help="the firmware tree's folder inside the repository (default: the folder you "
                             f"stand in, else firmware-pico/ when {last} has one, else the root)")
    parser.add_argument("-k", dest="keyword", default=None, metavar="EXPR",
                        help="only the suite's cases matching EXPR (faster; a change must show in them)")
    parser.add_argument("--firmware", default=None, metavar="RELEASE",
                        help="judge every commit as this release (as run --firmware)")


def _add_bisect(sub) -> None:  # type: ignore[no-untyped-def]
    bis = sub.add_parser(
        "bisect", help="find the first commit where the selected cases' verdicts (or output) change",
        description="In a git checkout of a firmware repository: build and run the commits between GOOD "
                    "and BAD (BAD's first-parent line) in a scratch worktree, halving as git bisect does, "
                    "and name the first commit whose selected cases' verdicts (--output: HAT output) "
                    "differ from GOOD's. Commits whose tree does not build are skipped. The checkout "
                    "itself is left as it is (docs/COMPARING-BUILDS.md).",
        epilog=exit_status_help("sil bisect"))
    bis.add_argument("good", metavar="GOOD", help="a commit whose behaviour is the reference")
    bis.add_argument("bad", metavar="BAD", help="a later commit whose behaviour differs")
    _add_repository_options(bis, "BAD")
    bis.add_argument("--output", action="store_true",
                     help="look for a change of the cases' HAT output, not of their verdicts")
    bis.add_argument("--work", default=os.path.join("reports", "bisect"), metavar="DIR",
                     help="where each step's run is kept (default %(default)s)")


def _bisect(args: argparse.Namespace) -> int:
    from .commit_bisection import BisectError, bisect

    extra = ["--firmware", args.firmware] if args.firmware else []
    try:
        result = bisect(Path(args.repo), args.good, args.bad, Path(args.work), folder=args.folder,
                        keyword=args.keyword, extra=extra, output=args.output,
                        say=lambda line: print(line, flush=True))
    except BisectError as exc:
        raise UsageError(str(exc)) from None
    what = "HAT output" if args.output else "verdicts"
    if result.first is None and not result.suspects:
        print(f"no change: the selected cases' {what} at BAD are GOOD's ({result.builds} build(s))")
        return 1
    if result.first is None:        # BAD, and the commits left before it, do not build
        listed = ", ".join(f"{c.short} {c.subject}" for c in result.suspects)
        print(f"no commit found: the change is in one of {len(result.suspects)} commit(s) that do not build: "
              f"{listed} ({result.builds} build(s))")
        return 1
    if len(result.suspects) > 1:
        listed = ", ".join(f"{c.short} {c.subject}" for c in result.suspects[:-1])
        print(f"{len(result.suspects) - 1} commit(s) just before the one below do not build (skipped): the "
              f"change may be in them: {listed}")
    first = result.first
    print(f"first changed: {first.sha} {first.subject}: {result.case} ({result.builds} build(s))")
    return 0


def _add_mutate_merge(sub) -> None:  # type: ignore[no-untyped-def]
    merge = sub.add_parser("mutate-merge",
                           help="one page and JSON from the parts of a sil mutate --shard campaign",
                           description="Merge the parts (--shard 1/N ... N/N) of one seeded sil mutate "
                                       "campaign, run on one machine each, into one page and one JSON.",
                           epilog=exit_status_help("sil mutate-merge"))
    merge.add_argument("parts", nargs="+", metavar="PART",
                       help="each part's mutation.json, or the --output folder holding it")
    merge.add_argument("-o", "--output", default=os.path.join("reports", "mutation"), metavar="DIR",
                       help="where the merged page and JSON go (default %(default)s)")


def _mutate_merge(args: argparse.Namespace) -> int:
    from .mutation_report import write_reports
    from .shards import MergeError, merge, read_part

    try:
        campaign = merge([read_part(Path(p)) for p in args.parts])
    except MergeError as exc:
        raise UsageError(str(exc)) from None
    out = Path(args.output)
    page = write_reports(campaign, out)
    print(campaign.summary_line())
    print(f"report: {page}  json: {out / 'mutation.json'}")
    return 0


def _add_history(sub) -> None:  # type: ignore[no-untyped-def]
    hist = sub.add_parser(
        "history", help="run the suite on every commit from FIRST to LAST (or a --shard of them)",
        description="In a git checkout of a firmware repository: build each commit of LAST's first-parent "
                    "line from FIRST on in a scratch worktree and run the suite on it; one line per "
                    "commit, a page and a JSON (docs/COMPARING-BUILDS.md).",
        epilog=exit_status_help("sil history"))
    hist.add_argument("first", metavar="FIRST", help="the first commit to run")
    hist.add_argument("last", metavar="LAST", help="the last commit to run (a descendant of FIRST)")
    _add_repository_options(hist, "LAST")
    hist.add_argument("--shard", default=None, metavar="K/N", help="run only every N-th commit from the K-th")
    hist.add_argument("-o", "--output", default=os.path.join("reports", "history"), metavar="DIR",
                      help="where the page, the JSON and each commit's run go (default %(default)s)")
    merge = sub.add_parser("history-merge", help="one page and JSON from the parts of a sil history --shard",
                           description="Merge the parts (--shard 1/N ... N/N) of one sil history run.",
                           epilog=exit_status_help("sil history-merge"))
    merge.add_argument("parts", nargs="+", metavar="PART", help="each part's history.json, or its folder")
    merge.add_argument("-o", "--output", default=os.path.join("reports", "history"), metavar="DIR",
                       help="where the merged page and JSON go (default %(default)s)")


def _history(args: argparse.Namespace) -> int:
    from .commit_bisection import BisectError
    from .commit_history import merge_history, read_history_part, run_history, write_history
    from .shards import MergeError, parse_shard

    try:
        if args.sil_command == "history-merge":
            data = merge_history([read_history_part(Path(p)) for p in args.parts])
        else:
            if args.shard is not None:
                parse_shard(args.shard)
            out = Path(args.output)
            extra = ["--firmware", args.firmware] if args.firmware else []
            data = run_history(Path(args.repo), args.first, args.last, out / "runs", folder=args.folder,
                               keyword=args.keyword, extra=extra, shard=args.shard,
                               say=lambda line: print(line, flush=True))
    except (BisectError, MergeError, ValueError) as exc:
        raise UsageError(str(exc)) from None
    page = write_history(data, Path(args.output))
    print(f"{len(data['commits'])} commit(s); report: {page}  json: {Path(args.output) / 'history.json'}")
    return 0
