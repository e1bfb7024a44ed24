"""Figures 4-8 of the paper's Sec. 5 from the CSVs that `hysid reproduce paper` writes (fig4_*.csv,
fig5_tau_nominal.csv, fig6_params_nominal.csv, fig7_tau_noisy.csv, fig8_params_noisy.csv, run.json),
and Fig. 2 (Example 6, ξ' = sin ξ) from the fig2_smoothness.csv that `hysid reproduce example6` writes:
columns t, xi, D (the Euler derivative D_δt ξ), tau (the smoothness bound τ) and tau_hat_r<r> (the
estimate τ̂ with bound scale r), one row per time."""
import json
import os
import re

import numpy as np

from . import data, style

PARAM_LABELS = {"a_hat": r"$\hat a$", "b_hat": r"$\hat b$", "lambda_hat": r"$\hat\lambda$", "mu_hat": r"$\hat\mu$"}


def read(run, name):
    """{column: array} of RUN_DIR/name."""
    path = os.path.join(run, name)
    if not os.path.exists(path):
        raise data.DataError(f"{path}: no such file (written by hysid reproduce paper --out {run})")
    with open(path) as f:
        header = f.readline().strip().split(",")
        try:
            body = np.loadtxt(f, delimiter=",", ndmin=2)
        except ValueError as e:
            raise data.DataError(f"{path}: {e}") from None
    if body.shape[0] == 0 or body.shape[1] != len(header):
        raise data.DataError(f"{path}: {body.shape[1]} columns of numbers, the header has {len(header)}")
    return {h: body[:, i] for i, h in enumerate(header)}


def truth(run):
    """The true a, b, λ, μ from run.json's "paper" line ("a=5, b=0.1, lambda=0.99, mu=0, ...")."""
    path = os.path.join(run, "run.json")
    if not os.path.exists(path):
        raise data.DataError(f"{path}: no such file (written by hysid reproduce paper)")
    with open(path) as f:
        text = json.load(f).get("paper", "")
    found = dict(re.findall(r"\b(a|b|lambda|mu)=([-+0-9.eE]+)", text))
    if len(found) != 4:
        raise data.DataError(f"{path}: key 'paper' does not give a=, b=, lambda=, mu= ('{text}')")
    return {k + "_hat": float(v) for k, v in found.items()}


def source(run, command="hysid reproduce paper"):
    return f"Data: {run} ({command})."


def fig4(run, out, formats, width):
    tr, jumps = read(run, "fig4_trajectory.csv"), read(run, "fig4_jumps.csv")
    fig, axes, leg, ncol = style.panels(width, 2, 2, panel_height=1.25 if width == "single" else 1.5, cols=1)
    for ax, key, label in [(axes[0], "x1", r"position $\xi_1$"), (axes[1], "x2", r"velocity $\xi_2$")]:
        (flow,) = ax.plot(tr["t"], tr[key], color=style.COLORS[0], lw=0.7, label="trajectory")
        ax.vlines(jumps["t_jump"], jumps["pre_" + key], jumps["post_" + key], color="0.3", lw=0.6, ls=":")
        (pre,) = ax.plot(jumps["t_jump"], jumps["pre_" + key], "o", mfc="none", color="0.2", ms=3,
                         label=r"state before a jump ($\xi \in D$)")
        ax.set_ylabel(label)
        if ax is axes[1]:
            ax.set_xlabel("t [s]")
        else:
            ax.tick_params(labelbottom=False)
    leg.legend([flow, pre], [flow.get_label(), pre.get_label()], loc="center", ncol=2)
    cap = (f"Fig. 4: the impact mass-spring-damper of Sec. 5 (a = 5, b = 0.1, λ = 0.99, μ = 0, ξ0 = (20, 0)); "
           f"dotted: the jumps. {source(run)}")
    return style.save(fig, out, "fig4", formats, cap)


def fig_tau(run, name, out, stem, formats, width, what):
    d = read(run, name)
    fig, axes, leg, ncol = style.panels(width, 2, 4, panel_height=1.3 if width == "single" else 1.6, cols=1)
    ax = axes[0]
    hs = [ax.semilogy(d["t"], np.where(d["D"] > 0, d["D"], np.nan), color="0.45", lw=0.5,
                      label=r"$\|D_{\delta t}\xi\|$ (Euler derivative)")[0]]
    jump = d["gamma"] > 0
    hs.append(ax.semilogy(d["t"][jump], d["D"][jump], "o", mfc="none", color="black", ms=3.5,
                          label="detected jump")[0])
    hs.append(ax.semilogy(d["t"], np.where(d["tau_hat"] > 0, d["tau_hat"], np.nan), color=style.COLORS[0],
                          lw=0.9, label=r"estimate $\hat\tau$")[0])
    hs.append(ax.semilogy(d["t"], np.where(d["r_tau"] > 0, d["r_tau"], np.nan), color=style.COLORS[1], lw=0.9,
                          ls="--", label=r"$r\,\tau$ (true bound, r = 220)")[0])
    ax.set_ylabel(r"$\|D_{\delta t}\xi\|$, $\hat\tau$, $r\tau$")
    ax.tick_params(labelbottom=False)
    e = d["e_tau"][1:]
    axes[1].semilogy(d["t"][1:], np.where(e > 0, e, np.nan), color=style.COLORS[0], lw=0.6)
    axes[1].set_ylabel(r"$e_\tau = |\hat\tau - r\tau|$")
    axes[1].set_xlabel("t [s]")
    leg.legend(hs, [h.get_label() for h in hs], loc="center", ncol=ncol)
    cap = (f"{what}: the Euler derivative, the detected jumps, the smoothness-bound estimate τ̂ and the true "
           f"bound rτ (top), and the error e_τ (bottom; log axes, zeros not drawn). {source(run)}")
    return style.save(fig, out, stem, formats, cap)


def fig_params(run, name, out, stem, formats, width, what):
    d = read(run, name)
    true = truth(run)
    fig, axes, leg, ncol = style.panels(width, 4, 5, panel_height=1.3 if width == "single" else 1.5, cols=2)
    hs = []
    for ax, keys, ylabel in [(axes[0], ("a_hat", "b_hat"), "flow parameters"),
                             (axes[1], ("lambda_hat", "mu_hat"), "jump parameters")]:
        for k in keys:
            i = len(hs)
            hs.append(ax.plot(d["t"], d[k], color=style.COLORS[i], ls=style.DASHES[i], lw=0.8,
                              label=PARAM_LABELS[k])[0])
            truth_line = ax.axhline(true[k], color="0.5", lw=0.6, ls=":", label="true value")
        # The first samples (one-row least squares from a flat prior) swing far off: zoom on t >= 1 s.
        late = np.concatenate([d[k][d["t"] >= 1.0] for k in keys] + [[true[k] for k in keys]])
        pad = 0.1 * (late.max() - late.min()) + 1e-3
        ax.set_ylim(late.min() - pad, late.max() + pad)
        ax.set_ylabel(ylabel)
        ax.tick_params(labelbottom=False)
    hs.append(truth_line)
    leg.legend(hs, [h.get_label() for h in hs], loc="center", ncol=len(hs))
    for ax, key, label in [(axes[2], "e_alpha", r"$e_\alpha$"), (axes[3], "e_beta", r"$e_\beta$")]:
        ax.semilogy(d["t"], np.where(d[key] > 0, d[key], np.nan), color=style.COLORS[0], lw=0.8)
        ax.set_ylabel(label)
        ax.set_xlabel("t [s]")
    cap = (f"{what}: the estimates â, b̂ (flow) and λ̂, μ̂ (jump) against time, zoomed on t ≥ 1 s, with the "
           f"true values dotted (top), and the errors e_α, e_β (bottom, log). {source(run)}")
    return style.save(fig, out, stem, formats, cap)


FIG2 = "fig2_smoothness.csv"


def fig2(run, out, formats, width):
    d = read(run, FIG2)
    for need in ("t", "xi", "D", "tau"):
        if need not in d:
            raise data.DataError(f"{os.path.join(run, FIG2)}: no column '{need}'")
    hats = sorted((float(k[len("tau_hat_r"):]), k) for k in d if k.startswith("tau_hat_r"))
    fig, axes, leg, ncol = style.panels(width, 2, 2 + len(hats), panel_height=1.2 if width == "single" else 1.4,
                                        cols=1)
    axes[0].plot(d["t"], d["xi"], color=style.COLORS[0], lw=0.9)
    axes[0].set_ylabel(r"$\xi$")
    axes[0].tick_params(labelbottom=False)
    hs = [axes[1].plot(d["t"], d["D"], color="black", lw=0.9, marker="o", ms=2.5, mfc="none",
                       markevery=max(1, d["t"].size // 20), label=r"$D_{\delta t}\xi$ (Euler derivative)")[0],
          axes[1].plot(d["t"], d["tau"], color=style.COLORS[1], lw=1.1, ls="--", label=r"$\tau$ (smoothness bound)")[0]]
    for i, (r, k) in enumerate(hats):
        hs.append(axes[1].plot(d["t"], d[k], color=style.COLORS[2 + i], ls=style.DASHES[(i + 2) % 4], lw=0.9,
                               label=rf"$\hat\tau$, r = {r:g}")[0])
    drawn = np.concatenate([d["D"], d["tau"]] + [d[k] for _, k in hats])
    pos = drawn[drawn > 0]
    if pos.size and pos.max() >= 100 * pos.min():  # spans two decades or more: a log axis
        style.set_value_axis(axes[1], drawn)
    axes[1].set_ylabel(r"$D_{\delta t}\xi$, $\tau$" + (r", $\hat\tau$" if hats else ""))
    axes[1].set_xlabel("t")
    leg.legend(hs, [h.get_label() for h in hs], loc="center", ncol=min(ncol, len(hs)))
    hat_text = f" and its estimate τ̂ for r = {', '.join(f'{r:g}' for r, _ in hats)}" if hats else ""
    cap = (f"Fig. 2: Example 6, ξ' = sin ξ on C = [0, 2π]: the state ξ (top), its Euler derivative "
           f"D_δt ξ and the smoothness bound τ = (1/δt)∫|ξ| ds over the last δt{hat_text} (bottom). "
           f"{source(run, 'hysid reproduce example6')}")
    return style.save(fig, out, "fig2", formats, cap)


def paper_figures(run, out_dir, formats, width):
    """The paper's figures whose CSVs RUN_DIR holds: fig2 (`hysid reproduce example6`, results/example6)
    and fig4 ... fig8 (`hysid reproduce paper`, results/paper), into out_dir (default RUN_DIR)."""
    out = out_dir or run
    written = []
    if os.path.exists(os.path.join(run, FIG2)):
        written += fig2(run, out, formats, width)
    if os.path.exists(os.path.join(run, "fig4_trajectory.csv")) or not written:
        written += (fig4(run, out, formats, width) +
                    fig_tau(run, "fig5_tau_nominal.csv", out, "fig5", formats, width, "Fig. 5: nominal (σ = 0)") +
                    fig_params(run, "fig6_params_nominal.csv", out, "fig6", formats, width,
                               "Fig. 6: nominal (σ = 0)") +
                    fig_tau(run, "fig7_tau_noisy.csv", out, "fig7", formats, width, "Fig. 7: noisy (σ = 0.25)") +
                    fig_params(run, "fig8_params_noisy.csv", out, "fig8", formats, width,
                               "Fig. 8: noisy (σ = 0.25)"))
    return written
