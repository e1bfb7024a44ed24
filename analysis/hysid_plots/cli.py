"""The command line: one subcommand per figure kind, `all`, and `table`."""
import argparse
import importlib
import os
import sys

PROG = "hysid_plots"
KINDS = {  # subcommand: (module, function, what it draws)
    "error-vs-sigma": ("sweep_figs", "error_vs_sigma", "e_α, e_β, misclassification vs σ per model and δt"),
    "misclassification-map": ("maps", "misclassification_map", "misclassification over δt × r per σ"),
    "detector-comparison": ("maps", "detector_comparison",
                            "best paper r in hindsight vs the residual detector over σ × δt (+ .csv, .md)"),
    "efficiency": ("sweep_figs", "efficiency", "mean error / CRLB-implied error vs σ (needs crlb_* columns)"),
    "relative-error": ("sweep_figs", "relative_error",
                       "per-parameter relative error vs σ, one panel per parameter (needs trials.csv)"),
    "coverage": ("sweep_figs", "coverage",
                 "share of trials whose reported 95 %% interval covers the truth vs σ (needs cover_* columns)"),
}
ALL_ORDER = ["error-vs-sigma", "relative-error", "efficiency", "coverage", "misclassification-map",
             "detector-comparison"]


def need_libraries(matplotlib=True):
    """Exits with a hint when numpy or matplotlib cannot be imported by this interpreter."""
    for name in ["numpy"] + (["matplotlib"] if matplotlib else []):
        try:
            importlib.import_module(name)
        except ImportError:
            sys.exit(f"{PROG}: error: {sys.executable} has no module '{name}': run with /usr/bin/python3 "
                     f"or install python3-{name} (apt-get install python3-{name})")


def formats(text):
    out = [f.strip() for f in text.split(",") if f.strip()]
    bad = [f for f in out if f not in ("pdf", "svg", "png")]
    if bad or not out:
        raise argparse.ArgumentTypeError(f"'{text}': must be pdf, svg, png or a comma list of them")
    return out


def truth(text):
    out = {}
    for part in text.split(","):
        name, eq, value = part.partition("=")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            raise argparse.ArgumentTypeError(f"'{part}': expected NAME=VALUE with a number") from None
        if not eq or not name.strip():
            raise argparse.ArgumentTypeError(f"'{part}': expected NAME=VALUE")
    return out


def run_list(text):
    try:
        out = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}': expected run numbers, e.g. 1,2,5") from None
    if not out or min(out) < 1:
        raise argparse.ArgumentTypeError(f"'{text}': run numbers start at 1")
    return out


def figure_options(p, paper=False, width="double"):
    p.add_argument("--format", type=formats, default=["png"], metavar="pdf|svg|png[,...]",
                   help="file format(s), e.g. pdf,png (default png)")
    p.add_argument("--width", choices=["single", "double"], default=width,
                   help=f"single column (3.5 in) or full width (7.16 in) of a two-column paper (default {width})")
    p.add_argument("--dpi", type=int, default=300, help="resolution of PNG files (default 300)")
    p.add_argument("--out", default=None, help="output directory (default RUN_DIR" + ("" if paper else "/figures")
                   + ")")
    if not paper:
        p.add_argument("--stat", choices=["mean", "median"], default="mean",
                       help="point statistic over each cell's trials (default mean)")
        p.add_argument("--truth", type=truth, default=None, metavar="NAME=VALUE,...",
                       help="true parameter values when run.json does not list them (relative-error)")


def parser():
    ap = argparse.ArgumentParser(prog=PROG, description="Figures and tables from hysid's result CSVs.")
    sub = ap.add_subparsers(dest="kind", required=True, metavar="KIND")
    for name, (_, _, what) in KINDS.items():
        p = sub.add_parser(name, help=what, description=what)
        p.add_argument("run_dir", metavar="RUN_DIR")
        figure_options(p)
    p = sub.add_parser("all", help="every figure kind that RUN_DIR's data allow (the others are named and skipped)")
    p.add_argument("run_dir", metavar="RUN_DIR")
    figure_options(p)
    p = sub.add_parser("paper", help="the paper's Figs. 4-8 (from `hysid reproduce paper`) or Fig. 2 (from "
                                     "`hysid reproduce example6`), whichever CSVs RUN_DIR holds")
    p.add_argument("run_dir", metavar="RUN_DIR", nargs="?", default="results/paper")
    figure_options(p, paper=True)
    p = sub.add_parser("fit", help="the figure of one identification: measured outputs with the fitted model, "
                                   "events with their standard errors, modes, hidden states with a band, "
                                   "detector, residuals with their autocorrelation and normal quantiles",
                       description="RUN: an `identify --json` report REPORT.json (its trace beside it: REPORT.csv) "
                                   "or their common prefix P (P.json, P.csv)")
    p.add_argument("run", metavar="RUN")
    p.add_argument("--runs", type=run_list, default=None, metavar="N[,N...]",
                   help="the runs of the data to draw, one figure each (default: the first 3)")
    figure_options(p, paper=True, width="single")
    p = sub.add_parser("table", help="the summary as a paper table (mean [95 %% interval] per cell)")
    p.add_argument("run_dir", metavar="RUN_DIR")
    p.add_argument("--format", choices=["md", "latex", "csv"], default="md")
    p.add_argument("--metrics", default=None, help="comma list (default e_alpha,e_beta,misclassification)")
    p.add_argument("--stat", choices=["mean", "median"], default="mean")
    p.add_argument("--out", default=None, help="output file (default standard output)")
    return ap


def draw(kind, run, args):
    mod, fn, _ = KINDS[kind]
    f = getattr(importlib.import_module(f"hysid_plots.{mod}"), fn)
    return f(run, args.out or os.path.join(run.dir, "figures"), args.format, args.width, args.stat)


def run_kind(args):
    from hysid_plots import data, style
    if args.dpi < 50:
        raise data.DataError(f"--dpi = {args.dpi}: must be >= 50")
    style.DPI = args.dpi
    if args.kind == "paper":
        from hysid_plots import paper
        return paper.paper_figures(args.run_dir, args.out, args.format, args.width)
    if args.kind == "fit":
        from hysid_plots import fit
        return fit.fit_figures(args.run, args.out, args.format, args.width, args.runs)
    run = data.Run(args.run_dir)
    run.truth = args.truth
    if args.kind != "all":
        return draw(args.kind, run, args)
    written = []
    for kind in ALL_ORDER:
        try:
            written += draw(kind, run, args)
        except data.DataError as e:
            print(f"{PROG}: skipped {kind}: {e}", file=sys.stderr)
    return written


def main(argv=None):
    args = parser().parse_args(argv)
    need_libraries(matplotlib=args.kind != "table")
    from hysid_plots import data
    try:
        if args.kind == "table":
            from hysid_plots import table
            text = table.render(data.Run(args.run_dir), args.format,
                                args.metrics.split(",") if args.metrics else None, args.stat)
            if args.out:
                with open(args.out, "w") as f:
                    f.write(text)
                print("wrote", args.out)
            else:
                sys.stdout.write(text)
            return 0
        for path in run_kind(args):
            print("wrote", path)
    except data.DataError as e:
        sys.exit(f"{PROG}: error: {e}")
    return 0
