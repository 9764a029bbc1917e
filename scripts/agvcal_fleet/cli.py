"""Command line of agvcal-fleet (docs/fleet.md): parses, dispatches to the modules that do
the work (none of which imports this one or each other's commands), prints errors."""
import argparse
import os
import sys

from .errors import UsageError

DEFAULT_DB = os.environ.get("AGVCAL_FLEET_DB", "fleet.sqlite")
# The system Python's packages the commands import when they need them.
DEBIAN_PACKAGES = {"dask": "python3-dask", "distributed": "python3-distributed",
                   "numpy": "python3-numpy", "scipy": "python3-scipy", "yaml": "python3-yaml"}


class Parser(argparse.ArgumentParser):
    """Usage errors as one line and exit status 2."""

    def error(self, message):
        raise UsageError(f"{self.prog}: {message}")


def add_db(p):
    p.add_argument("--db", default=DEFAULT_DB, metavar="URL",
                   help="results database: a SQLite file (default %(default)s, or $AGVCAL_FLEET_DB), "
                        "or postgresql://USER@HOST[:PORT]/DB (also ?host=/socket/dir)")


def add_analysis(p):
    p.add_argument("--alpha", type=float, default=0.01,
                   help="family-wise false-alarm rate over all robots, parameters and tests "
                        "(default %(default)s)")
    p.add_argument("--min-recordings", type=int, default=5,
                   help="recordings a robot needs before its trends are tested (default %(default)s)")
    p.add_argument("--window-days", type=float, default=7.0,
                   help="an effect appearing in several robots within this many days is "
                        "fleet-wide (default %(default)s)")
    p.add_argument("--fleet-min-robots", type=int, default=3,
                   help="robots an effect must appear in to be fleet-wide (default %(default)s)")


def build_parser():
    ap = Parser(prog="agvcal-fleet", description=(
        "agvcal across a fleet: `agvcal solve` (with the held-out check) and `agvcal diagnose` "
        "on every recording, as tasks on Dask distributed; results in a database; drift, steps "
        "and fleet-wide effects as decisions and an HTML report. Exit status: 0 done, 2 unusable "
        "input (one line naming the file and the key), 1 internal error, 130 interrupted."))
    sub = ap.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)

    p = sub.add_parser("run", help="process the fleet's new recordings", description=(
        "Runs agvcal info, solve, solve --fit-fraction 0.5 and diagnose on every recording of "
        "FLEET not yet in the database (keyed by the recording's content hash and its robot "
        "file's), as tasks on a Dask LocalCluster (default) or a running scheduler, and writes "
        "each result as it arrives. A recording that fails gives rows with its exit status and "
        "message. Progress on stderr."))
    p.add_argument("fleet", metavar="FLEET",
                   help="fleet.yaml (robot id -> robot file, glob of recordings), or a folder tree "
                        "in which every folder with a robot.yaml is a robot and its *.log files its "
                        "recordings")
    add_db(p)
    p.add_argument("--scheduler", metavar="tcp://HOST:8786",
                   help="a running Dask scheduler (`dask scheduler`, workers `dask worker "
                        "tcp://HOST:8786`); the recordings and agvcal must be at the same paths on "
                        "every worker (shared storage)")
    p.add_argument("--connect-timeout", type=float, default=30, metavar="S",
                   help="seconds to wait for the scheduler (default %(default)s)")
    p.add_argument("--workers", type=int, default=max(1, os.cpu_count() or 1),
                   help="LocalCluster worker processes (default: one per core, %(default)s)")
    p.add_argument("--threads", type=int, default=1,
                   help="tasks at a time per LocalCluster worker (default %(default)s)")
    p.add_argument("--agvcal", metavar="PATH",
                   help="the agvcal binary (default: $AGVCAL_BIN, build/agvcal of this checkout, "
                        "or agvcal on PATH)")
    p.add_argument("--task-timeout", type=float, default=900, metavar="S",
                   help="seconds one agvcal command may take (default %(default)s)")
    p.add_argument("--nice", type=int, default=0, help="niceness added to the agvcal commands")
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")

    p = sub.add_parser("analyze", help="trends, drift and step tests, fleet-wide effects",
                       description=(
        "Reads the database, tests every robot's parameters for drift (weighted regression on "
        "time) and steps (best change point), finds effects that appear in many robots at once, "
        "stores the decisions in the findings table and prints them. Never reads a simulator's "
        "truth."))
    add_db(p)
    add_analysis(p)
    p.add_argument("--json", metavar="FILE", help="also write the findings as JSON")
    p.add_argument("--quiet", action="store_true", help="print nothing")

    p = sub.add_parser("report", help="HTML report with SVG plots", description=(
        "Runs the analysis and writes DIR/index.html (the fleet at a glance: which robots need "
        "attention and why, fleet-wide effects, failed recordings) and one page per robot with "
        "each parameter's trend and sigma band, its drift and step tests, and its effects."))
    add_db(p)
    add_analysis(p)
    p.add_argument("--out", required=True, metavar="DIR", help="folder for the report")

    p = sub.add_parser("migrate", help="create or update the database schema", description=(
        "Creates the schema in an empty database or brings an older one to this version "
        "(run also does this); prints the version."))
    add_db(p)

    p = sub.add_parser("synth", help="make a synthetic fleet with the simulator (tests, benchmark)",
                       description=(
        "Writes a fleet of simulated robots to OUT: fleet.yaml, robot files, simulation configs, "
        "recordings (agvcal simulate, demo trajectory) and truth.json. Robots have their own "
        "true parameters; some drift, some have a step on a known day, some get a fleet-wide "
        "effect (a lidar latency after a firmware update). See docs/fleet.md."))
    p.add_argument("out", metavar="OUT")
    p.add_argument("--robots", type=int, default=10, help="robots (default %(default)s)")
    p.add_argument("--recordings", type=int, default=10, help="recordings per robot (default %(default)s)")
    p.add_argument("--days", type=float, default=70, help="span in days (default %(default)s)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--drift-share", type=float, default=0.1)
    p.add_argument("--step-share", type=float, default=0.1)
    p.add_argument("--effect-share", type=float, default=0.15)
    p.add_argument("--effect-day", type=float, help="day of the fleet-wide effect (default 0.6 x span)")
    p.add_argument("--plan", help="scenario per robot instead of the shares, e.g. "
                                  "'constant,drift@forklift,step,effect' (drive diff or forklift)")
    p.add_argument("--broken", type=int, default=0, help="add N truncated recordings (they fail)")
    p.add_argument("--trajectory", default="demo")
    p.add_argument("--jobs", type=int, default=max(1, os.cpu_count() or 1))
    p.add_argument("--nice", type=int, default=0)
    p.add_argument("--agvcal", metavar="PATH")
    p.add_argument("--force", action="store_true", help="overwrite a fleet in OUT")
    p.add_argument("--quiet", action="store_true")
    return ap


def analyze_and_report(args):
    """`analyze` and `report`: the decisions from the database, stored in it (findings), then
    printed or written as the HTML report."""
    from . import analyze
    from . import db as dbmod
    db = dbmod.Database(args.db)
    db.migrate()
    robots = analyze.load(db)
    result = analyze.analyze(robots, alpha=args.alpha, min_recordings=args.min_recordings,
                             window_days=args.window_days, fleet_min_robots=args.fleet_min_robots)
    analyze.store(db, result["findings"])
    if args.command == "report":
        from . import report
        report.write(args.out, robots, result, db, report.provenance(args.db))
        print(f"agvcal-fleet: report in {args.out}/index.html", file=sys.stderr)
    else:
        if args.json:
            analyze.write_json(args.json, result)
        if not args.quiet:
            print("\n".join(analyze.summary(robots, result)))
    db.close()
    return 0


def main(argv=None):
    ap = build_parser()
    try:
        args = ap.parse_args(argv)
        if not args.command:
            ap.print_help(sys.stderr)
            return 2
        if args.command == "run":
            from . import runner
            if args.workers < 1 or args.threads < 1:
                raise UsageError("agvcal-fleet run: --workers and --threads must be at least 1")
            return runner.run(args)
        if args.command in ("analyze", "report"):
            if not 0 < args.alpha < 1:
                raise UsageError(f"agvcal-fleet {args.command}: --alpha must lie in (0, 1)")
            return analyze_and_report(args)
        if args.command == "migrate":
            from . import db as dbmod
            db = dbmod.Database(args.db)
            applied = db.migrate()
            print(f"schema version {dbmod.SCHEMA_VERSION}" +
                  (f" (applied {', '.join(map(str, applied))})" if applied else " (up to date)"))
            return 0
        if args.command == "synth":
            from . import synth, runner
            args.agvcal = runner.find_agvcal(args.agvcal)
            return synth.synth(args)
    except UsageError as e:
        print(f"agvcal-fleet: error: {e}", file=sys.stderr)
        return 2
    except ModuleNotFoundError as e:
        top = (e.name or "").split(".")[0]
        if top not in DEBIAN_PACKAGES:
            raise
        print(f"agvcal-fleet: error: the Python module {top} is not installed (Debian package "
              f"{DEBIAN_PACKAGES[top]}; scripts/setup.sh installs it)", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("agvcal-fleet: interrupted", file=sys.stderr)
        return 130
    return 1
