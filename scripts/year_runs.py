"""The full reproduction (``hvacflex reproduce [--energyplus]``) less the named runs.

Runs the full plan's jobs on Dask into ``OUT/runs/<run name>`` (the folders the command uses,
so a later ``hvacflex reproduce --out OUT`` on the same code re-uses them) and builds the same
report from them; the runs left out are missing from its tables. This is how a year too long
for one sitting is made in parts (docs/explanation/reproduction.md).

    python scripts/year_runs.py OUT [--energyplus] [--skip RUN ...] [--workers N]

Example: the year with (b) but not (c) under affine feedback, RC plant only:

    python scripts/year_runs.py results/year --skip rmpc-feedback-ppp
"""

import argparse
import time
from pathlib import Path

from hvacflex.reproduce import run_and_report
from hvacflex.reproduce_plan import Plan, plan_groups


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--energyplus", action="store_true")
    parser.add_argument("--skip", nargs="*", default=[], metavar="RUN")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    plan = Plan.full(energyplus=args.energyplus)
    groups = plan_groups(plan)
    names = {cfg.name for jobs in groups.values() for _, cfg in jobs}
    unknown = sorted(set(args.skip) - names)
    if unknown:
        parser.error(f"--skip: no run named {', '.join(unknown)}; runs: {', '.join(sorted(names))}")
    groups = {g: [(p, c) for p, c in jobs if c.name not in args.skip] for g, jobs in groups.items()}
    t0 = time.time()
    result = run_and_report(plan, groups, args.out, workers=args.workers)
    failed = [o.label for o in result.outcomes if not o.ok]
    print(f"{time.time() - t0:.0f} s wall (runs and report); failed: {failed}")


if __name__ == "__main__":
    main()
