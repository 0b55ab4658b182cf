"""The full reproduction (``hvacflex reproduce [--energyplus]``) less the named runs.

Runs the full plan's jobs on Dask into ``OUT/runs/<run name>`` (the folders the command uses,
so a later ``hvacflex reproduce --out OUT`` on the same code re-uses them) and builds the same
report from them; the runs left out are missing from its tables. This is how a year too long
for one sitting is made in parts (docs/reproduction.md).

    python scripts/year_runs.py OUT [--energyplus] [--skip RUN ...] [--workers N]

Example: the year with (b) but not (c) under affine feedback, RC plant only:

    python scripts/year_runs.py results/year --skip rmpc-feedback-ppp
"""

import argparse
import time
from pathlib import Path

from hvacflex.report.html import write_report
from hvacflex.reproduce import run_groups
from hvacflex.reproduce_plan import Plan, plan_groups
from hvacflex.reproduce_report import build_sections


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
    args.out.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    by_group = run_groups(groups, args.out, workers=args.workers)
    t1 = time.time()
    failed = [o.label for jobs in by_group.values() for o in jobs if not o.ok]
    path = write_report(
        args.out,
        title="hvacflex — reproduction of Hanif et al. (2016)"
        + (f" (less {', '.join(args.skip)})" if args.skip else ""),
        sections=build_sections(plan, by_group, args.out),
    )
    print(f"runs: {t1 - t0:.0f} s wall; report: {time.time() - t1:.0f} s; failed: {failed}")
    print(f"report: {path}")


if __name__ == "__main__":
    main()
