"""Tests on one parameter's series of calibrations (t_i, y_i, sigma_i) of one robot.

Everything is weighted by 1/sigma^2 and takes a noise scale f >= 1 by which the sigmas are
multiplied (estimated from the fleet's scatter, `pooled_scale`). Pure Python (no numpy).

- drift: weighted linear regression of y on t; z = slope / its standard error.
- step: for every split (at least `min_side` recordings on each side) the weighted two-sample
  z of the means after and before; the largest |z| is the change point, its p-value
  multiplied by the number of splits tried (Bonferroni).
The caller multiplies again by the number of tests over the fleet (analyze.py).
"""
import math


def p_two_sided(z):
    """P(|N(0,1)| >= |z|)."""
    return math.erfc(abs(z) / math.sqrt(2.0))


def weighted_mean(y, s):
    w = [1.0 / (si * si) for si in s]
    sw = sum(w)
    m = sum(wi * yi for wi, yi in zip(w, y)) / sw
    return m, 1.0 / sw  # mean, its variance (unit scale)


def chi2_const(y, s):
    m, _ = weighted_mean(y, s)
    return sum(((yi - m) / si) ** 2 for yi, si in zip(y, s))


def linear_fit(t, y, s):
    """Weighted least squares y = a + b (t - tw): (a, b, var_b, chi2, tw) at unit scale."""
    w = [1.0 / (si * si) for si in s]
    sw = sum(w)
    tw = sum(wi * ti for wi, ti in zip(w, t)) / sw
    stt = sum(wi * (ti - tw) ** 2 for wi, ti in zip(w, t))
    a = sum(wi * yi for wi, yi in zip(w, y)) / sw
    if stt <= 0:
        return a, 0.0, math.inf, chi2_const(y, s), tw
    b = sum(wi * (ti - tw) * yi for wi, ti, yi in zip(w, t, y)) / stt
    chi2 = sum(wi * (yi - a - b * (ti - tw)) ** 2 for wi, ti, yi in zip(w, t, y))
    return a, b, 1.0 / stt, chi2, tw


def drift_test(t, y, s, scale=1.0):
    """{slope, slope_std, z, p, chi2 (of the line, unit scale), a, tw}."""
    a, b, var_b, chi2, tw = linear_fit(t, y, s)
    sd = scale * math.sqrt(var_b) if math.isfinite(var_b) else math.inf
    z = b / sd if sd > 0 and math.isfinite(sd) else 0.0
    return {"slope": b, "slope_std": sd, "z": z, "p": p_two_sided(z), "chi2": chi2, "a": a, "tw": tw}


def step_test(y, s, scale=1.0, min_side=2):
    """Best change point of the series (in time order): {k (first index of the new level),
    before, after, size, size_std, z, p (Bonferroni over the splits), splits, chi2 (of the
    two-level model, unit scale)}, or None with fewer than 2 * min_side values."""
    n = len(y)
    if n < 2 * min_side:
        return None
    best = None
    for k in range(min_side, n - min_side + 1):
        m0, v0 = weighted_mean(y[:k], s[:k])
        m1, v1 = weighted_mean(y[k:], s[k:])
        sd = scale * math.sqrt(v0 + v1)
        z = (m1 - m0) / sd
        if best is None or abs(z) > abs(best["z"]):
            best = {"k": k, "before": m0, "after": m1, "size": m1 - m0, "size_std": sd, "z": z}
    splits = n - 2 * min_side + 1
    best["splits"] = splits
    best["p"] = min(1.0, splits * p_two_sided(best["z"]))
    k = best["k"]
    best["chi2"] = chi2_const(y[:k], s[:k]) + chi2_const(y[k:], s[k:])
    return best


def chi2_median(k):
    """Median of the chi-square distribution with k degrees of freedom (Wilson-Hilferty)."""
    return k * (1.0 - 2.0 / (9.0 * k)) ** 3 if k > 0 else 0.0


def median(xs):
    xs = sorted(xs)
    n = len(xs)
    if not n:
        return math.nan
    return xs[n // 2] if n % 2 else 0.5 * (xs[n // 2 - 1] + xs[n // 2])


_NULL_MEDIAN = {}


def null_median_best_chi2(n):
    """Median, for n values of pure unit noise at equal spacing, of the smaller chi-square
    of the two models (line, best step): by a seeded simulation (deterministic), cached."""
    if n not in _NULL_MEDIAN:
        import random
        rng = random.Random(1000 + n)
        t = [float(i) for i in range(n)]
        s = [1.0] * n
        vals = []
        for _ in range(801):
            y = [rng.gauss(0.0, 1.0) for _ in range(n)]
            c = linear_fit(t, y, s)[3]
            st = step_test(y, s)
            vals.append(min(c, st["chi2"]) if st else c)
        _NULL_MEDIAN[n] = median(vals)
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
    if k <= 0:
        return 1.0
    if k > n:
        return 0.0
    total = 0.0
    for i in range(k, n + 1):
        total += math.exp(math.lgamma(n + 1) - math.lgamma(i + 1) - math.lgamma(n - i + 1)
                          + i * math.log(p) + (n - i) * math.log1p(-p))
    return min(1.0, total)
