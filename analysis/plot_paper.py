#!/usr/bin/python3
"""Figures 4-8 of the paper's Sec. 5 from the CSVs of `hysid reproduce paper`.

Usage: /usr/bin/python3 analysis/plot_paper.py [RUN_DIR]   (default results/paper)
Writes fig4.png ... fig8.png into RUN_DIR. Uses only the CSVs in RUN_DIR.
"""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read(path):
    with open(path, newline="") as f:
        rows = [r for r in csv.reader(f) if r and not r[0].startswith("#")]
    header, body = rows[0], rows[1:]
    return {h: [float(r[i]) for r in body] for i, h in enumerate(header)}


def fig4(run, out):
    tr = read(os.path.join(run, "fig4_trajectory.csv"))
    jumps = read(os.path.join(run, "fig4_jumps.csv"))
    fig, ax = plt.subplots(2, 1, sharex=True, figsize=(7, 4.5))
    for i, (key, label) in enumerate([("x1", r"$\xi_1$ (position)"), ("x2", r"$\xi_2$ (velocity)")]):
        ax[i].plot(tr["t"], tr[key], "b-", lw=0.8)
        ax[i].plot(jumps["t_jump"], jumps["pre_" + key], "o", color="0.5", ms=3)
        for t, a, b in zip(jumps["t_jump"], jumps["pre_" + key], jumps["post_" + key]):
            ax[i].plot([t, t], [a, b], "b:", lw=0.8)
        ax[i].set_ylabel(label)
    ax[1].set_xlabel("t [s]")
    fig.suptitle("Fig. 4: impact mass-spring-damper (a=5, b=0.1, λ=0.99)")
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)


def fig_tau(path, out, title):
    d = read(path)
    fig, ax = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
    ax[0].semilogy(d["t"], d["D"], "k:", lw=0.6, label=r"$D_{\delta t}\xi$")
    jt = [t for t, g in zip(d["t"], d["gamma"]) if g > 0]
    jd = [v for v, g in zip(d["D"], d["gamma"]) if g > 0]
    ax[0].semilogy(jt, jd, "ko", ms=3, label="detected jumps")
    ax[0].semilogy(d["t"], d["tau_hat"], "b-", lw=0.8, label=r"$\hat\tau$")
    ax[0].semilogy(d["t"], d["r_tau"], "r--", lw=0.8, label=r"$r\,\tau$")
    ax[0].legend(fontsize=8, loc="upper right")
    e = [max(v, 1e-12) for v in d["e_tau"][1:]]
    ax[1].semilogy(d["t"][1:], e, "b-", lw=0.6)
    ax[1].set_ylabel(r"$e_\tau = |\hat\tau - r\tau|$")
    ax[1].set_xlabel("t [s]")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)


def fig_params(path, out, title, truth):
    d = read(path)
    fig, ax = plt.subplots(2, 2, sharex=True, figsize=(9, 5))
    for key, lab in [("a_hat", r"$\hat a$"), ("b_hat", r"$\hat b$")]:
        ax[0, 0].plot(d["t"], d[key], lw=0.8, label=lab)
        ax[0, 0].axhline(truth[key], color="0.6", lw=0.5, ls="--")
    for key, lab in [("lambda_hat", r"$\hat\lambda$"), ("mu_hat", r"$\hat\mu$")]:
        ax[0, 1].plot(d["t"], d[key], lw=0.8, label=lab)
        ax[0, 1].axhline(truth[key], color="0.6", lw=0.5, ls="--")
    # The first samples (one-row least squares from a flat prior) swing far off: zoom on t >= 1 s.
    for a, keys in [(ax[0, 0], ("a_hat", "b_hat")), (ax[0, 1], ("lambda_hat", "mu_hat"))]:
        late = [v for k in keys for t, v in zip(d["t"], d[k]) if t >= 1.0] + [truth[k] for k in keys]
        lo, hi = min(late), max(late)
        pad = 0.1 * (hi - lo) + 1e-3
        a.set_ylim(lo - pad, hi + pad)
    ax[0, 0].legend(fontsize=8)
    ax[0, 1].legend(fontsize=8)
    ax[1, 0].semilogy(d["t"], [max(v, 1e-16) for v in d["e_alpha"]], "b-", lw=0.8)
    ax[1, 0].set_ylabel(r"$e_\alpha$")
    ax[1, 1].semilogy(d["t"], [max(v, 1e-16) for v in d["e_beta"]], "b-", lw=0.8)
    ax[1, 1].set_ylabel(r"$e_\beta$")
    ax[1, 0].set_xlabel("t [s]")
    ax[1, 1].set_xlabel("t [s]")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)


def main(run):
    truth = {"a_hat": 5.0, "b_hat": 0.1, "lambda_hat": 0.99, "mu_hat": 0.0}
    fig4(run, os.path.join(run, "fig4.png"))
    fig_tau(os.path.join(run, "fig5_tau_nominal.csv"), os.path.join(run, "fig5.png"),
            "Fig. 5: nominal (no noise): Euler derivative and smoothness bound")
    fig_params(os.path.join(run, "fig6_params_nominal.csv"), os.path.join(run, "fig6.png"),
               "Fig. 6: nominal: parameter estimates and errors", truth)
    fig_tau(os.path.join(run, "fig7_tau_noisy.csv"), os.path.join(run, "fig7.png"),
            "Fig. 7: noisy (σ = 0.25): Euler derivative and smoothness bound")
    fig_params(os.path.join(run, "fig8_params_noisy.csv"), os.path.join(run, "fig8.png"),
               "Fig. 8: noisy (σ = 0.25): parameter estimates and errors", truth)
    print("wrote " + ", ".join(os.path.join(run, f"fig{i}.png") for i in range(4, 9)))


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "results/paper")
