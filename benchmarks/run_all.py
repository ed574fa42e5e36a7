"""Run the benchmarks and print every table (Markdown); this is what ``make bench`` runs.

    python benchmarks/run_all.py                     # everything, full size (speed's HD and 4K cases: ~10 min)
    python benchmarks/run_all.py --quick             # small crops and scenes, fewer iterations (a few minutes)
    python benchmarks/run_all.py --only middlebury   # a subset: middlebury, zkey, throughput, speed

The report is also written to ``benchmarks/out/report.md`` (``report_quick.md`` with --quick); figures go to
``benchmarks/out/``. Benchmarks print tables and write figures; they are not tests and gate nothing, but the
exit status is 1 when a benchmark raised.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import time
import traceback

import common  # benchmarks/ is on sys.path when run as a script

BENCHMARKS = {
    "middlebury": "middlebury",
    "zkey": "zkey_scenes",
    "zkey_edges": "zkey_edges",
    "softedge_passes": "softedge_passes",
    "throughput": "throughput",
    "speed": "speed",
}
"""Benchmark name -> module; each module has ``run(*, quick=False) -> str`` (Markdown)."""


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small inputs, fewer iterations")
    parser.add_argument("--only", nargs="+", choices=list(BENCHMARKS), default=list(BENCHMARKS),
                        help="run only these benchmarks")
    args = parser.parse_args(argv)

    parts = [f"# vfxstereo benchmarks{' (--quick)' if args.quick else ''}\n\n"
             f"Machine: {common.machine_line()}\n"]
    failed = []
    spent = []
    for name in args.only:
        print(f"[{name}] running ...", file=sys.stderr, flush=True)
        t0 = time.perf_counter()
        try:
            module = importlib.import_module(BENCHMARKS[name])
            parts.append(module.run(quick=args.quick))
        except Exception:  # a benchmark that fails must not stop the others
            failed.append(name)
            parts.append(common.section(f"{name}: FAILED", "```\n" + traceback.format_exc() + "```"))
        spent.append((name, time.perf_counter() - t0))
        print(f"[{name}] {spent[-1][1]:.1f} s", file=sys.stderr, flush=True)
    parts.append(common.section("Wall clock per benchmark (s)",
                                common.markdown_table(["benchmark", "seconds"], spent, digits=1)))
    report = "".join(parts)
    print(report)
    path = common.out_dir() / ("report_quick.md" if args.quick else "report.md")
    path.write_text(report)
    print(f"(written to {path})", file=sys.stderr)
    if failed:
        print(f"FAILED: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
