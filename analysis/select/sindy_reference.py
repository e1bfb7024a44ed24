"""SINDy's sequentially thresholded least squares on finite-difference derivatives: the reference for
hysid's selection of candidate terms (docs/method.md#which-model-candidate-terms).

Brunton, Proctor, Kutz, "Discovering governing equations from data by sparse identification of
nonlinear dynamical systems", PNAS 113 (2016): the derivative of the measured state is estimated
from the samples, a library Θ(X) of candidate functions is evaluated at the samples, and
Ẋ ≈ Θ(X) Ξ is solved by `sparsify_dynamics` (least squares, zero the coefficients below λ, re-solve
on the rest, repeat). Here the derivative is the central difference inside each flow segment (the
samples between jumps; the reference is given the true jump times), the library columns are
normalised to unit RMS before thresholding, the supports are those of the λ path, of forward
selection and every support of at most two terms (as hysid adds them), and one is chosen by the same
rule as hysid's (K-fold cross-validation over the segments, the fewest terms within one standard
error of the least held-out mean square) or by BIC, so that the comparison measures the regression,
not the rule.
"""
from __future__ import annotations

import itertools

import numpy as np

# muParser's functions as numpy ones (the library's terms are written as in a model file).
_NAMES = {"abs": np.abs, "sign": np.sign, "sin": np.sin, "cos": np.cos, "exp": np.exp, "sqrt": np.sqrt,
          "tanh": np.tanh, "atan": np.arctan, "ln": np.log, "log": np.log}


def evaluate_terms(terms, variables):
    """Θ: one column per term (a muParser expression of the named variables, ^ for powers)."""
    k = len(next(iter(variables.values())))
    cols = []
    for term in terms:
        value = eval(str(term).replace("^", "**"), {"__builtins__": {}}, {**_NAMES, **variables})
        cols.append(np.broadcast_to(np.asarray(value, dtype=float), (k,)))
    return np.column_stack(cols)


def flow_segments(jump_counter):
    """[start, end) index ranges of the samples between jumps (a jump: the counter changes)."""
    j = np.asarray(jump_counter)
    cuts = np.flatnonzero(np.diff(j) != 0) + 1
    bounds = np.concatenate([[0], cuts, [len(j)]])
    return [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:]) if b - a >= 3]


def central_differences(t, x, segments):
    """(indices, derivative, segment id) at each interior sample of each segment."""
    idx, dx, seg = [], [], []
    for s, (a, b) in enumerate(segments):
        k = np.arange(a + 1, b - 1)
        idx.append(k)
        dx.append((x[k + 1] - x[k - 1]) / (t[k + 1] - t[k - 1]))
        seg.append(np.full(len(k), s))
    return np.concatenate(idx), np.concatenate(dx), np.concatenate(seg)


def sparsify_dynamics(theta, dxdt, lam, iterations=10):
    """Brunton et al.'s sparsifyDynamics for one state: ξ with |ξ_j| < λ set to 0, re-solved."""
    xi = np.linalg.lstsq(theta, dxdt, rcond=None)[0]
    for _ in range(iterations):
        small = np.abs(xi) < lam
        xi[small] = 0.0
        big = ~small
        if not big.any():
            break
        xi[big] = np.linalg.lstsq(theta[:, big], dxdt, rcond=None)[0]
    return xi


def _solve(gram, cross, support):
    """Least squares on the columns `support` from the normal equations."""
    return np.linalg.solve(gram[np.ix_(support, support)], cross[support])


def _cv_score(folds, support):
    """Held-out mean square over the folds (each: train and test normal equations) and its standard error."""
    errors, rss, rows = [], 0.0, 0
    for (g_tr, c_tr), (g_te, c_te, s_te, n_te) in folds:
        coef = _solve(g_tr, c_tr, support) if support.any() else np.zeros(0)
        e = s_te - 2.0 * coef @ c_te[support] + coef @ g_te[np.ix_(support, support)] @ coef
        errors.append(e / n_te)
        rss += e
        rows += n_te
    if len(errors) < 2:
        return np.inf, 0.0
    return rss / rows, float(np.std(errors, ddof=1) / np.sqrt(len(errors)))


def _small_and_forward(gram, cross, square, exhaustive):
    """Every support of at most `exhaustive` columns, and forward selection's (add the column whose
    fit leaves the least residual sum of squares), as hysid's selection adds them to its path."""
    p = len(cross)
    out = []
    for k in range(1, exhaustive + 1):
        for cols in itertools.combinations(range(p), k):
            s = np.zeros(p, dtype=bool)
            s[list(cols)] = True
            out.append(s)
    s = np.zeros(p, dtype=bool)
    for _ in range(p):
        best, least = -1, np.inf
        for j in np.flatnonzero(~s):
            t = s.copy()
            t[j] = True
            g = gram[np.ix_(t, t)]
            if np.linalg.cond(g) > 1e13:
                continue
            rss = square - cross[t] @ np.linalg.solve(g, cross[t])
            if rss < least:
                best, least = j, rss
        if best < 0:
            break
        s = s.copy()
        s[best] = True
        out.append(s)
    return out


def select(theta, dxdt, seg, thresholds=40, rule="cv", folds=5, exhaustive=2):
    """The support (boolean per column) and coefficients chosen by `rule` ("cv" or "bic") among those of
    the λ path, forward selection and every support of at most `exhaustive` columns."""
    scale = np.sqrt(np.mean(theta * theta, axis=0))
    scale[scale == 0] = 1.0
    normal = theta / scale
    full = np.abs(np.linalg.lstsq(normal, dxdt, rcond=None)[0])
    lo, hi = full[full > 0].min(), full.max()
    supports = {}
    for lam in np.exp(np.linspace(np.log(lo * 0.999), np.log(hi * 1.001), thresholds)):
        s = sparsify_dynamics(normal, dxdt, lam) != 0
        supports.setdefault(s.tobytes(), s)
    gram, cross, n = normal.T @ normal, normal.T @ dxdt, len(dxdt)
    for s in _small_and_forward(gram, cross, float(dxdt @ dxdt), exhaustive):
        supports.setdefault(s.tobytes(), s)
    fold_sums = []
    for f in range(folds):
        test = seg % folds == f
        if not test.any() or test.all():
            continue
        g_te, c_te = normal[test].T @ normal[test], normal[test].T @ dxdt[test]
        fold_sums.append(((gram - g_te, cross - c_te), (g_te, c_te, float(dxdt[test] @ dxdt[test]), int(test.sum()))))
    scores = []
    for s in supports.values():
        coef = _solve(gram, cross, s) if s.any() else np.zeros(0)
        r = dxdt - normal[:, s] @ coef if s.any() else dxdt
        rss = float(r @ r)
        bic = n * np.log(rss / n) + s.sum() * np.log(n)
        cv, se = _cv_score(fold_sums, s) if rule == "cv" else (0.0, 0.0)
        scores.append((s, bic, cv, se))
    if rule == "bic":
        best = min(scores, key=lambda x: x[1])[0]
    else:
        least = min(scores, key=lambda x: x[2])
        within = [x for x in scores if x[2] <= least[2] + least[3]]
        best = min(within, key=lambda x: (x[0].sum(), x[2]))[0]
    coef = np.zeros(theta.shape[1])
    if best.any():
        coef[best] = np.linalg.lstsq(normal[:, best], dxdt, rcond=None)[0] / scale[best]
    return best, coef


def identify_row(t, states, jump_counter, row, terms, rule="cv"):
    """SINDy on one row: `states` maps names to sample arrays, `row` names the differentiated state."""
    segments = flow_segments(jump_counter)
    idx, dxdt, seg = central_differences(t, states[row], segments)
    theta = evaluate_terms(terms, {name: x[idx] for name, x in states.items()})
    return select(theta, dxdt, seg, rule=rule)
