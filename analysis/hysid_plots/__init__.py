"""hysid_plots: figures and tables of hysid's result CSVs (summary.csv, trials.csv, run.json).

Run: /usr/bin/python3 analysis/hysid_plots KIND RUN_DIR [--format pdf,png] [--width single|double]
(or `python3 -m hysid_plots` with analysis/ on PYTHONPATH); `--help` lists the kinds.
"""
