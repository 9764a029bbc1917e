"""Tests on one parameter's series of calibrations (t_i, y_i, sigma_i) of one robot.

Everything is weighted by 1/sigma^2 and takes a noise scale f >= 1 by which the sigmas are
multiplied (estimated from the fleet's scatter, `pooled_scale`). The distributions from
scipy.special (scipy.stats would add a second to every start), the weighted sums with numpy
(scipy has no regression with known sigmas).

- drift: weighted linear regression of y on t; z = slope / its standard error.
- step: for every split (at least `min_side` recordings on each side) the weighted two-sample
  z of the means after and before; the largest |z| is the change point, its p-value
  multiplied by the number of splits tried (Bonferroni).
The caller multiplies again by the number of tests over the fleet (analyze.py).
Results are plain Python numbers (they go to JSON and the database).
"""
import math
import random

import numpy as np
from scipy import special


def p_two_sided(z):
    """P(|N(0,1)| >= |z|)."""
    return float(2.0 * special.ndtr(-abs(z)))


def _weights(s):
    s = np.asarray(s, dtype=float)
    return 1.0 / (s * s)


def weighted_mean(y, s):
    """(mean, its variance at unit scale)."""
    w = _weights(s)
    sw = w.sum(-1)
    return float(np.dot(w, np.asarray(y, dtype=float)) / sw), float(1.0 / sw)


def _line(t, y, w):
    """Weighted least squares y = a + b (t - tw) along the last axis (one series, or one per
    row): a, b, var_b (unit scale; inf when t is constant), chi2, tw."""
    sw = w.sum(-1)
    tw = (w * t).sum(-1) / sw
    dt = t - tw[..., None]
    stt = (w * dt * dt).sum(-1)
    a = (w * y).sum(-1) / sw
    flat = stt <= 0
    b = np.where(flat, 0.0, (w * dt * y).sum(-1) / np.where(flat, 1.0, stt))
    chi2 = (w * (y - a[..., None] - b[..., None] * dt) ** 2).sum(-1)
    var_b = np.where(flat, np.inf, 1.0 / np.where(flat, 1.0, stt))
    return a, b, var_b, chi2, tw


def _best_step(y, w, min_side):
    """The split with the largest |z| of every row of y (series in time order) at unit scale:
    k (first index of the new level), mean before, after, their variances, and the chi2 of
    the two-level model, one per row."""
    rows, n = y.shape
    ks = np.arange(min_side, n - min_side + 1)
    w_before, wy_before = np.cumsum(w, 1), np.cumsum(w * y, 1)
    w_after = np.cumsum(w[:, ::-1], 1)[:, ::-1]
    wy_after = np.cumsum((w * y)[:, ::-1], 1)[:, ::-1]
    w0, w1 = w_before[:, ks - 1], w_after[:, ks]
    m0, m1 = wy_before[:, ks - 1] / w0, wy_after[:, ks] / w1
    z = (m1 - m0) / np.sqrt(1.0 / w0 + 1.0 / w1)
    r, i = np.arange(rows), np.argmax(np.abs(z), 1)  # the first of equal |z|
    k, m0, m1, w0, w1 = ks[i], m0[r, i], m1[r, i], w0[r, i], w1[r, i]
    level = np.where(np.arange(n) < k[:, None], m0[:, None], m1[:, None])
    chi2 = (w * (y - level) ** 2).sum(1)
    return k, m0, m1, 1.0 / w0, 1.0 / w1, chi2


def _by_length(series):
    """{n: indices of the series of n values}: series of one length are computed together."""
    groups = {}
    for i, x in enumerate(series):
        groups.setdefault(len(x[0]), []).append(i)
    return groups


def drift_tests(series, scales=None):
    """`drift_test` of every (t, y, s) of SERIES with its noise scale (default 1), in order."""
    out = [None] * len(series)
    for n, idx in _by_length(series).items():
        t, y, s = (np.array([series[i][c] for i in idx], dtype=float) for c in range(3))
        f = np.array([1.0 if scales is None else scales[i] for i in idx])
        a, b, var_b, chi2, tw = _line(t, y, _weights(s))
        sd = f * np.sqrt(var_b)
        ok = np.isfinite(sd) & (sd > 0)
        z = np.where(ok, b / np.where(ok, sd, 1.0), 0.0)
        p = 2.0 * special.ndtr(-np.abs(z))
        for j, i in enumerate(idx):
            out[i] = {"slope": float(b[j]), "slope_std": float(sd[j]), "z": float(z[j]), "p": float(p[j]),
                      "chi2": float(chi2[j]), "a": float(a[j]), "tw": float(tw[j])}
    return out


def drift_test(t, y, s, scale=1.0):
    """{slope, slope_std, z, p, chi2 (of the line, unit scale), a, tw}."""
    return drift_tests([(t, y, s)], [scale])[0]


def step_tests(series, scales=None, min_side=2):
    """`step_test` of every (y, s) of SERIES with its noise scale (default 1), in order."""
    out = [None] * len(series)
    for n, idx in _by_length(series).items():
        if n < 2 * min_side:
            continue
        y, s = (np.array([series[i][c] for i in idx], dtype=float) for c in range(2))
        f = np.array([1.0 if scales is None else scales[i] for i in idx])
        k, m0, m1, v0, v1, chi2 = _best_step(y, _weights(s), min_side)
        sd = f * np.sqrt(v0 + v1)
        z = (m1 - m0) / sd
        splits = n - 2 * min_side + 1
        p = np.minimum(1.0, splits * (2.0 * special.ndtr(-np.abs(z))))
        for j, i in enumerate(idx):
            out[i] = {"k": int(k[j]), "before": float(m0[j]), "after": float(m1[j]),
                      "size": float(m1[j] - m0[j]), "size_std": float(sd[j]), "z": float(z[j]),
                      "splits": splits, "p": float(p[j]), "chi2": float(chi2[j])}
    return out


def step_test(y, s, scale=1.0, min_side=2):
    """Best change point of the series (in time order): {k (first index of the new level),
    before, after, size, size_std, z, p (Bonferroni over the splits), splits, chi2 (of the
    two-level model, unit scale)}, or None with fewer than 2 * min_side values."""
    return step_tests([(y, s)], [scale], min_side)[0]


def median(xs):
    """The median (nan of nothing)."""
    return float(np.median(xs)) if len(xs) else math.nan


_NULL_MEDIAN = {}


def null_median_best_chi2(n):
    """Median, for n values of pure unit noise at equal spacing, of the smaller chi-square
    of the two models (line, best step): by a seeded simulation (deterministic), cached."""
    if n not in _NULL_MEDIAN:
        rng = random.Random(1000 + n)
        y = np.array([[rng.gauss(0.0, 1.0) for _ in range(n)] for _ in range(801)])
        w = np.ones_like(y)
        best = _line(np.arange(n, dtype=float), y, w)[3]
        if n >= 4:
            best = np.minimum(best, _best_step(y, w, 2)[5])
        _NULL_MEDIAN[n] = median(best)
    return _NULL_MEDIAN[n]


def pooled_scale(fits):
    """Noise scale f >= 1 from several series [(best chi2, n), ...], the best chi2 being the
    smaller of the line's and the best step's: the median over the series of best chi2 /
    its median under pure noise, square-rooted. Robust: a robot that drifts or steps fits
    one of the models and does not inflate it, and the median ignores a minority that fits
    neither; sigmas too small for the scatter are widened, sigmas too large are kept
    (conservative)."""
    ratios = [c / null_median_best_chi2(n) for c, n in fits if n >= 4]
    if not ratios:
        return 1.0
    return max(1.0, math.sqrt(median(ratios)))


def binomial_sf(k, n, p):
    """P(X >= k), X ~ Binomial(n, p)."""
    return float(special.bdtrc(k - 1, n, p))  # P(X > k - 1)
