#!/usr/bin/python3
"""Simulate N noise draws of each user system into DIR/SYSTEM/drawNN/ (README.md here).

    generate.py --hysid build/bin/hysid --out DIR [--draws 20] [--systems ball,impact,...]

Per draw: truth.csv (+ truth.json, jumps.csv: `hysid simulate`'s files, the truth), data.csv (what a
user has: time, the measured states, the inputs; the dropout's rows removed, the missing rows NaN),
start.toml (the model file with the draw's start values), inputs.csv (models with inputs), draw.json.
"""
import argparse
import sys

import systems


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hysid", required=True, help="path of the hysid binary")
    ap.add_argument("--out", required=True, help="directory of the draws")
    ap.add_argument("--draws", type=int, default=20)
    ap.add_argument("--systems", default=",".join(s.name for s in systems.SYSTEMS))
    args = ap.parse_args(argv)
    names = args.systems.split(",")
    for i, s in enumerate(systems.SYSTEMS):
        if s.name not in names:
            continue
        for d in range(args.draws):
            systems.generate_draw(args.hysid, args.out, i, s, d)
        print(f"{s.name}: {args.draws} draws in {args.out}/{s.name}")


if __name__ == "__main__":
    sys.exit(main())
