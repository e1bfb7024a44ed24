#!/usr/bin/python3
"""Time two hysid binaries on the user systems' draws, draw by draw with the binaries alternating.

    compare_times.py --before OLD/hysid --after NEW/hysid --work DIR [--draws 20] [--systems ball,...]

The machine's speed can move by more than the change measured within minutes, so each draw's fit
(`hysid identify` with its defaults on the draw's start file, as evaluate.py runs it) is timed with
one binary and then the other before the next draw. Prints per system the median and the sum of the
wall times of each binary, and whether the two give the same status and estimates on every draw.
The draws must exist (generate.py, or a run of evaluate.py).
"""
import argparse
import statistics
import sys
import tempfile
from pathlib import Path

import systems
from evaluate import identify


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", required=True, help="the binary before the change")
    ap.add_argument("--after", required=True, help="the binary after it")
    ap.add_argument("--work", required=True, help="the draws' directory (generate.py --out)")
    ap.add_argument("--draws", type=int, default=20)
    ap.add_argument("--systems", default=",".join(s.name for s in systems.SYSTEMS))
    args = ap.parse_args(argv)
    names = args.systems.split(",")
    unknown = sorted(set(names) - {s.name for s in systems.SYSTEMS})
    if unknown:
        print(f"compare_times.py: --systems: unknown system(s) {', '.join(unknown)}", file=sys.stderr)
        return 2
    binaries = {"before": args.before, "after": args.after}
    same_everywhere = True
    with tempfile.TemporaryDirectory() as scratch:
        for s in (s for s in systems.SYSTEMS if s.name in names):
            wall = {tag: [] for tag in binaries}
            fits = {tag: [] for tag in binaries}
            for d in range(args.draws):  # draw_dir's index: 0 for draw01
                draw = systems.draw_dir(args.work, s, d)
                if not (draw / "start.toml").exists():
                    print(f"compare_times.py: {draw}/start.toml: no such draw (run generate.py)", file=sys.stderr)
                    return 2
                # identify writes its report beside the data; a copy of the data keeps the
                # evaluation's own reports untouched.
                here = Path(scratch) / f"{s.name}-{d}"
                here.mkdir()
                (here / "data.csv").write_bytes((draw / "data.csv").read_bytes())
                for tag, hysid in binaries.items():
                    r = identify(hysid, here, draw / "start.toml", tag)
                    wall[tag].append(r["wall"])
                    fits[tag].append((r["status"], r.get("estimate")))
            for tag in binaries:
                w = wall[tag]
                print(f"{s.name:<11} {tag:<6} median {statistics.median(w):.3f} s  sum {sum(w):.1f} s")
            same = fits["before"] == fits["after"]
            same_everywhere &= same
            print(f"{s.name:<11} same status and estimates on every draw: {'yes' if same else 'NO'}")
    return 0 if same_everywhere else 1


if __name__ == "__main__":
    sys.exit(main())
