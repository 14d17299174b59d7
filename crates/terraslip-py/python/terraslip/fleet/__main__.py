"""``python -m terraslip.fleet``: the fleet's tables and report from the shell."""

from __future__ import annotations

import argparse
import sys
from typing import List, Optional

DESCRIPTION = """\
Runs terraslip on every recording of a fleet, one Dask task per recording,
into Parquet tables partitioned by robot and date (docs/fleet.md).

A recording is a log directory (wheels.csv, ...), a ROS 2 bag directory
(metadata.yaml) or a .mcap / .db3 file, as a local path or an fsspec URL
(s3://, gs://, az://, ... with that filesystem's package installed). A
directory that is not a recording is searched for recordings. A manifest
(.csv or .parquet) lists them: columns path, robot[, date][, topics]; paths
relative to the manifest. Without a robot column, the robot is the bag's
metadata.yaml custom_data robot, the log's meta.toml robot, or else the
name of the directory holding the recording.
"""

EPILOG = """\
examples:
  # the repository's data/ on 2 local worker processes, then the report
  python -m terraslip.fleet estimate data --topics husky.toml --out fleet --scheduler local:2
  python -m terraslip.fleet calibrate data --topics husky.toml --out fleet --scheduler local:2
  python -m terraslip.fleet report fleet              # fleet/report.html

  # a manifest on object storage, on a running Dask cluster
  python -m terraslip.fleet estimate s3://bucket/fleet.csv --out s3://bucket/tables \\
      --scheduler tcp://scheduler:8786 --rows

  # query the tables
  duckdb -c "SELECT robot, date, avg(controller_factor) FROM
    read_parquet('fleet/recordings/*/*/*.parquet', hive_partitioning=true) GROUP BY ALL"

A recording that fails is a row with its error; the exit status is 0 when
the tables were written (2 when no recording succeeded), 1 on a bad argument.
"""


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m terraslip.fleet",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    def common(sp: argparse.ArgumentParser) -> None:
        sp.add_argument("fleet", nargs="+", metavar="PATHS_OR_MANIFEST", help="recordings, directories of recordings, or manifests (.csv/.parquet)")
        sp.add_argument("--out", required=True, metavar="DIR", help="output directory (path or URL); its tables are replaced once the new ones are written")
        sp.add_argument(
            "--scheduler",
            metavar="local:N|ADDRESS",
            default=None,
            help="local:N runs N worker processes here (default: one per CPU); tcp://HOST:PORT uses a running Dask scheduler",
        )
        sp.add_argument("--robot", help="robot name of every recording found from paths (not manifests)")
        sp.add_argument("--topics", metavar="FILE.toml", help="for ROS 2 bags: which topic feeds which stream, as `terraslip import --topics` (a manifest's topics column wins)")
        sp.add_argument("--quiet", action="store_true", help="no progress or dashboard link")

    e = sub.add_parser(
        "estimate",
        help="terraslip estimate on every recording -> OUT/recordings (+ rows, tracks)",
        description="Runs `terraslip estimate` on every recording: OUT/recordings/ (one row per recording), OUT/tracks/ (map points of recordings with a pose reference), OUT/rows/ with --rows (every estimate.csv row).",
    )
    common(e)
    e.add_argument("--config", metavar="FILE.toml", help="estimator configuration, as `terraslip estimate --config`")
    e.add_argument("--preset", help="named estimator variant, as `terraslip estimate --preset` (e.g. ta-iekf)")
    e.add_argument(
        "--terrain-labels",
        choices=("auto", "yes", "no"),
        default="auto",
        help="use a log's terrain.csv as the terrain evidence (--terrain-labels): auto = when it has one (default)",
    )
    e.add_argument("--rows", action="store_true", help="also write every estimate row (OUT/rows/; about 90 bytes per row)")
    e.add_argument("--report", action="store_true", help="also write OUT/report.html")

    c = sub.add_parser(
        "calibrate",
        help="terraslip calibrate per robot and terrain -> OUT/calibrations",
        description="Calibrates each robot on each terrain from all of its drives there (one `terraslip calibrate` per group; drives need a pose reference): OUT/calibrations/.",
    )
    common(c)
    c.add_argument("--method", choices=("lm", "ga", "symmetric"), help="identification method (default: all three, the best kept, as the command)")

    r = sub.add_parser("report", help="OUT/report.html from the tables in OUT", description="Writes the fleet report (HTML) from an output directory's tables.")
    r.add_argument("out", metavar="DIR")
    r.add_argument("--html", metavar="FILE", help="where to write it (default DIR/report.html)")
    return p


def main(argv: Optional[List[str]] = None) -> int:
    args = _parser().parse_args(argv)
    from . import FleetError, calibrate, estimate, recordings, report

    try:
        if args.command == "report":
            print(f"wrote {report(args.out, args.html)}", file=sys.stderr)
            return 0
        recs = recordings(args.fleet, robot=args.robot)
        if args.command == "estimate":
            labels = {"auto": "auto", "yes": True, "no": False}[args.terrain_labels]
            table = estimate(
                recs,
                args.out,
                scheduler=args.scheduler,
                config=args.config,
                preset=args.preset,
                topics=args.topics,
                terrain_labels=labels,
                rows=args.rows,
                progress=not args.quiet,
            )
            name, what = "recordings", "recordings"
        else:
            table = calibrate(recs, args.out, scheduler=args.scheduler, method=args.method, topics=args.topics, progress=not args.quiet)
            name, what = "calibrations", "robot and terrain groups"
    except (FleetError, FileNotFoundError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    errors = [r for r in table.to_pylist() if r.get("error")]
    for r in errors:
        first = r["error"].splitlines()[0]
        print(f"warning: {r.get('path') or r['robot'] + '/' + (r.get('terrain') or 'unlabelled')}: {first}", file=sys.stderr)
    print(f"{args.command}: {table.num_rows - len(errors)} of {table.num_rows} {what} without error -> {args.out}/{name}", file=sys.stderr)
    if args.command == "estimate" and args.report:
        print(f"wrote {report(args.out)}", file=sys.stderr)
    return 2 if table.num_rows and len(errors) == table.num_rows else 0


if __name__ == "__main__":
    sys.exit(main())
