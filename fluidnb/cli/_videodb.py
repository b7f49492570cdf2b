"""``fluidnb videodb build|add|info``: video databases of fluid clips (Okabe et al., sec. 4)."""

from __future__ import annotations

import contextlib

from ._common import add_params_options
from ._paths import add_input, add_output

_STARTERS = ("water", "smoke", "fire")


def register(sub):
    """Add the ``videodb`` subcommand and its actions."""
    from ..videodb import DatabaseParams

    p = sub.add_parser(
        "videodb",
        help="build, grow and inspect video databases of fluid clips (Okabe et al. 2011)",
        description=(
            "A video database holds fluid clips cut into 48 x 48-pixel fragments of N "
            "frames (each clip also flipped, scaled 50/75/100 %% and rotated -22.5/0/+22.5 "
            "degrees), with each fragment's mean image, dense-SIFT visual words, mean "
            "motion, motion spectra and textureness: what `fluidnb animate` needs to "
            "bring a still photo of fluid to life."
        ),
    )
    actions = p.add_subparsers(dest="action", metavar="ACTION")
    p.set_defaults(func=lambda args: p.print_help() or 0)

    b = actions.add_parser(
        "build",
        help="build a database from clips, or the starter databases",
        description=(
            "Build a database in the new folder OUT from SOURCES (video files: .mp4 .webm "
            ".mov .avi .mkv .gif, or folders of frames), or, with --starter, the starter "
            "databases fluidnb makes from its own simulated clips (cached)."
        ),
        epilog=(
            "Examples: fluidnb videodb build --starter all | "
            "fluidnb videodb build mydb river1.mp4 river2.mp4 --kind water --workers 2"
        ),
    )
    add_output(b, "out", kind="folder", nargs="?", metavar="OUT", help="the new database folder")
    add_input(b, "sources", nargs="*", metavar="SOURCES", help="clips to put in")
    b.add_argument("--kind", default=None, help="water, smoke, fire or your own label")
    b.add_argument(
        "--starter",
        choices=(*_STARTERS, "all"),
        default=None,
        help="build (or find in the cache) a starter database instead",
    )
    b.add_argument(
        "--quick",
        action="store_true",
        help="the small starter databases (also when FLUIDNB_QUICK is set)",
    )
    b.add_argument("--rebuild", action="store_true", help="rebuild a cached starter database")
    b.add_argument("--resume", action="store_true", help="continue an interrupted build in OUT")
    b.add_argument("--seed", type=int, default=0, help="seed of the codebook (default 0)")
    _add_parallel_options(b)
    add_params_options(b, DatabaseParams)
    b.set_defaults(func=_build)

    a = actions.add_parser(
        "add",
        help="add clips to a database (with its codebook)",
        description=(
            "Add SOURCES to the database DB; it keeps its codebook and parameters. An "
            "interrupted addition is continued with --resume (and the same SOURCES) or "
            "discarded with --discard (and no SOURCES)."
        ),
        epilog="Examples: fluidnb videodb add mydb river3.mp4 | fluidnb videodb add mydb --discard",
    )
    add_output(a, "db", kind="folder", metavar="DB", help="the database folder (clips are added)")
    add_input(a, "sources", nargs="*", metavar="SOURCES", help="clips to add")
    how = a.add_mutually_exclusive_group()
    how.add_argument("--resume", action="store_true", help="continue an interrupted addition")
    how.add_argument(
        "--discard",
        action="store_true",
        help="discard an interrupted addition: the database stays as it was",
    )
    _add_parallel_options(a)
    a.set_defaults(func=_add)

    i = actions.add_parser(
        "info",
        help="what a database holds",
        description=(
            "List a database's clips, fragments and parameters; with --verify, check "
            "every chunk of it too."
        ),
        epilog=(
            "Examples: fluidnb videodb info mydb | fluidnb videodb info water --quick | "
            "fluidnb videodb info mydb --verify"
        ),
    )
    i.add_argument("db", metavar="DB", help="a database folder, or water / smoke / fire")
    i.add_argument("--quick", action="store_true", help="the quick starter database")
    i.add_argument(
        "--verify",
        action="store_true",
        help="read every chunk of every array and check its checksum; list each damaged "
        "or missing one (exit status 2 if any)",
    )
    i.set_defaults(func=_info)


def _add_parallel_options(parser):
    parser.add_argument(
        "--workers", type=int, default=None, help="threads of the local scheduler (default: all)"
    )
    parser.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="a dask.distributed scheduler to run on (e.g. tcp://10.0.0.5:8786)",
    )


#: Seconds to reach a --scheduler before giving up (dask's default is 30 s).
_CONNECT_TIMEOUT = 5


@contextlib.contextmanager
def _client(args):
    """The dask.distributed Client of ``--scheduler`` (closed afterwards), or None."""
    if not args.scheduler:
        yield None
        return
    try:
        from distributed import Client
    except ImportError:
        raise ValueError("--scheduler needs dask.distributed: pip install distributed") from None
    try:
        client = Client(args.scheduler, timeout=_CONNECT_TIMEOUT)
    except (OSError, ValueError, TypeError) as exc:  # refused, timed out, malformed
        raise ValueError(
            f"--scheduler: cannot reach a dask scheduler at {args.scheduler!r} within "
            f"{_CONNECT_TIMEOUT} s ({exc}); check the address, or leave --scheduler out to "
            "build on this machine"
        ) from None
    with client:
        yield client


def _run(args, write, *positional, **options):
    """Build or add (``write``) with the parallel options, then print the database."""
    from .._progress import TextProgress

    with _client(args) as client:
        db = write(
            *positional,
            client=client,
            workers=args.workers,
            resume=args.resume,
            progress=TextProgress(),
            **options,
        )
    print(db.summary())
    return 0


def _build(args):
    from .._progress import TextProgress
    from ..videodb import DatabaseParams, build_database, starter_database
    from ._common import params_from_args

    if args.starter:
        if args.out or args.sources:
            raise ValueError("--starter builds into the cache: give no OUT or SOURCES")
        kinds = _STARTERS if args.starter == "all" else (args.starter,)
        for kind in kinds:
            db = starter_database(
                kind, quick=args.quick or None, rebuild=args.rebuild, progress=TextProgress()
            )
            print(f"{kind}: {db.n_fragments} fragments from {len(db.clips)} clips in {db.path}")
        return 0
    if not args.out or not args.sources:
        raise ValueError("give the new database folder OUT and at least one clip in SOURCES")
    if not args.kind:
        raise ValueError("--kind is required: water, smoke, fire or your own label")
    params = params_from_args(DatabaseParams, args)
    return _run(
        args,
        build_database,
        args.sources,
        args.out,
        kind=args.kind,
        params=params,
        seed=args.seed,
    )


def _add(args):
    from ..videodb import add_clips, discard_addition, open_database

    if args.discard:
        if args.sources:
            raise ValueError("--discard takes no SOURCES: it removes what the addition left")
        names = discard_addition(args.db)
        print(f"discarded the interrupted addition of {', '.join(map(repr, names)) or 'clips'}")
        print(open_database(args.db).summary())
        return 0
    if not args.sources:
        raise ValueError("give at least one clip in SOURCES (or --discard)")
    return _run(args, add_clips, args.db, args.sources)


def _info(args):
    import sys

    from .._progress import TextProgress
    from ..videodb import open_database, starter_path, verify_database

    path = args.db
    if args.db in _STARTERS:
        path = starter_path(args.db, quick=args.quick or None)
        if not path.exists():
            quick = " --quick" if args.quick else ""
            raise ValueError(
                f"the starter {args.db} database is not built yet: run "
                f"`fluidnb videodb build --starter {args.db}{quick}`"
            )
    if args.verify:
        problems = verify_database(path, progress=TextProgress())
        if problems:
            for line in problems:
                print(line)
            print(
                f"fluidnb videodb: error: {path}: {len(problems)} damaged or missing parts "
                "(listed above)",
                file=sys.stderr,
            )
            return 2
    db = open_database(path)
    print(db.summary())
    if args.verify:
        print(
            "  verified: every chunk is present and its checksum matches"
            if db.checked
            else "  verified: every chunk decodes and the in-memory arrays match the manifest"
        )
    return 0
