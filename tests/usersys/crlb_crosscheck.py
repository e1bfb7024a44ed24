#!/usr/bin/python3
"""The finite-difference bound (systems.fd_crlb) against `hysid crlb` on a draw's full sample grid.

    crlb_crosscheck.py --hysid build/bin/hysid --work DIR [--draw 1] [--rel 1e-6] [--steps 1e-5,1e-8]

Prints, per system where `hysid crlb` runs, the ratio finite-difference sd / hysid crlb sd of every
unknown (README.md here, "The bound"); where it does not run, with --steps, the finite-difference sd
at each of the steps over the one at --rel.
"""
import argparse
import sys

import systems


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hysid", required=True)
    ap.add_argument("--work", required=True)
    ap.add_argument("--draw", type=int, default=1)
    ap.add_argument("--rel", type=float, default=1e-6, help="relative step of the differences")
    ap.add_argument("--steps", default="", help="comma-separated relative steps to compare where "
                    "hysid crlb does not run")
    args = ap.parse_args(argv)
    for i, s in enumerate(systems.SYSTEMS):
        path = systems.draw_dir(args.work, s, args.draw - 1)
        if not (path / "draw.json").exists():
            systems.generate_draw(args.hysid, args.work, i, s, args.draw - 1)
        sd, why = systems.hysid_crlb(args.hysid, s, path)
        grid = [r["t"] for r in systems.read_csv(path / "truth.csv")]
        if sd is None:
            print(f"{s.name}: hysid crlb: {why}")
            ref = systems.fd_crlb(args.hysid, s, path, grid, rel=args.rel) if args.steps else {}
            for step in filter(None, args.steps.split(",")):
                fd = systems.fd_crlb(args.hysid, s, path, grid, rel=float(step))
                print(f"  step {step} over {args.rel:g}: "
                      + ", ".join(f"{n} {fd[n] / ref[n]:.4f}" for n in fd))
            continue
        fd = systems.fd_crlb(args.hysid, s, path, grid, rel=args.rel)
        print(f"{s.name}: " + ", ".join(f"{n} {fd[n] / sd[n]:.4f}" for n in fd))
    return 0


if __name__ == "__main__":
    sys.exit(main())
