"""Statistics of a tolerance study: distributions, confidence intervals, yield, linear propagation, shares.

Confidence intervals are 95 %, **analytic and asymptotic** (no resampling, so a summary is a
deterministic function of the samples), over the designs that assemble fully (status ``ok``):

* ``mean_ci``: :math:`\\bar y \\pm z\\, s/\\sqrt n` (central limit theorem);
* ``std_ci``: :math:`s \\pm z\\,\\mathrm{SE}(s)` with the distribution-free delta method
  :math:`\\mathrm{SE}(s^2)^2 = (m_4 - s^4 (n-3)/(n-1))/n`, :math:`\\mathrm{SE}(s) = \\mathrm{SE}(s^2)/2s`
  (valid for any distribution with a fourth moment, unlike the chi-square interval);
* ``p99_ci``: the order statistics of ranks :math:`n p \\mp z\\sqrt{n p (1-p)}` (binomial,
  distribution-free);
* ``yield``: share of all designs with status ``ok``, with the Wilson score interval.

``linear_std`` is the first-order propagated standard deviation
:math:`\\sqrt{\\sum_i (\\partial y/\\partial x_i)^2 \\sigma_i^2}` (independent inputs) and ``linear_mean``
:math:`y_0 + \\sum_i \\partial y/\\partial x_i\\, \\mu_i` (the offsets' means); ``linear_share`` each
key's term over their sum.  ``contribution`` is the first-order Sobol index
:math:`\\mathrm{Var}(E[y\\mid x_i])/\\mathrm{Var}(y)` estimated from the Monte Carlo samples by
equal-count binning of :math:`x_i` into :math:`B = \\min(50, \\lfloor\\sqrt n\\rfloor)` bins, its
null bias :math:`(B-1)/(n-1)` subtracted (floored at 0).

A load that is the solver's round-off in the nominal design and in every sampled one -- its value at most
:data:`~dualmech.core.thresholds.ROUND_OFF_RELATIVE` of the largest peak of its unit group in the same
design (:data:`~dualmech.models.tolerance.outputs.LOAD_GROUPS`), e.g. j4's moment with a ball joint at the
slider -- is **structurally zero**: ``round_off`` gives its level (the largest value seen), and it is
reported as 0 (nominal, statistics, linear propagation, sensitivities: its exact derivative), with no
variance shares (``None``).

An output that does not vary beyond round-off over the nominal design and the sampled ones -- its spread at
most :data:`CONSTANT_RELATIVE` of its magnitude, e.g. joint 1's moment when it is the given drive torque --
is **constant**: ``constant`` gives its spread; it has no distribution to draw and no variance shares
(``None``: a share of a variance that is round-off is noise).
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np
from scipy.special import ndtri

from dualmech.core.thresholds import ROUND_OFF_RELATIVE
from dualmech.models.tolerance.outputs import LOAD_GROUPS, DesignStatus
from dualmech.models.tolerance.sensitivity import Sensitivities
from dualmech.models.tolerance.spec import Spec

#: Two-sided 95 % normal quantile.
Z95 = float(ndtri(0.975))
#: Quantiles reported per output.
QUANTILES: dict[str, float] = {"p01": 0.01, "p50": 0.50, "p99": 0.99, "p999": 0.999}
#: Most bins of the Sobol estimator (more bins: less bias from within-bin trends, more noise).
MAX_SOBOL_BINS = 50


def _nan_pair() -> list[float]:
    return [float("nan"), float("nan")]


def describe(y: np.ndarray) -> dict:
    """Mean, std, quantiles and their 95 % intervals of one output over ``n`` designs ``(n,)``."""
    y = np.sort(y[np.isfinite(y)])
    n = y.size
    if n < 2:
        nan = float("nan")
        return {"n": int(n), "mean": float(y.mean()) if n else nan, "std": nan,
                **{k: (float(y[0]) if n else nan) for k in QUANTILES},
                "mean_ci": _nan_pair(), "std_ci": _nan_pair(), "p99_ci": _nan_pair()}
    mean, std = float(y.mean()), float(y.std(ddof=1))
    m4 = float(np.mean((y - mean) ** 4))
    se_var = math.sqrt(max(m4 - std**4 * (n - 3) / (n - 1), 0.0) / n)
    se_std = se_var / (2.0 * std) if std > 0 else 0.0
    half = Z95 * math.sqrt(0.99 * 0.01 * n)
    lo_rank, hi_rank = (int(np.clip(math.floor(0.99 * n + s * half), 0, n - 1)) for s in (-1, 1))
    return {"n": int(n), "mean": mean, "std": std,
            **{k: float(np.quantile(y, q)) for k, q in QUANTILES.items()},
            "mean_ci": [mean - Z95 * std / math.sqrt(n), mean + Z95 * std / math.sqrt(n)],
            "std_ci": [std - Z95 * se_std, std + Z95 * se_std],
            "p99_ci": [float(y[lo_rank]), float(y[hi_rank])]}


def wilson(k: int, n: int) -> dict:
    """Share ``k / n`` and its 95 % Wilson score interval."""
    if n == 0:
        return {"value": float("nan"), "ci": _nan_pair(), "ok": 0, "n": 0}
    p = k / n
    centre = (p + Z95**2 / (2 * n)) / (1 + Z95**2 / n)
    half = Z95 * math.sqrt(p * (1 - p) / n + Z95**2 / (4 * n * n)) / (1 + Z95**2 / n)
    return {"value": p, "ci": [max(0.0, centre - half), min(1.0, centre + half)], "ok": int(k), "n": int(n)}


def sobol_first_order(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """First-order Sobol indices ``(k,)`` of ``y`` ``(n,)`` on inputs ``x`` ``(n, k)`` (module docstring)."""
    ok = np.isfinite(y)
    x, y = x[ok], y[ok]
    n = y.size
    var = float(y.var())
    if n < 4 or var == 0.0:
        return np.full(x.shape[1], np.nan)
    bins = max(2, min(MAX_SOBOL_BINS, int(math.isqrt(n))))
    out = []
    for col in x.T:
        rank = np.empty(n, dtype=int)
        rank[np.argsort(col, kind="stable")] = np.arange(n)
        b = rank * bins // n
        counts = np.bincount(b, minlength=bins)
        means = np.bincount(b, weights=y, minlength=bins) / np.maximum(counts, 1)
        between = float(np.sum(counts * (means - y.mean()) ** 2)) / n
        out.append(max(0.0, between / var - (bins - 1) / (n - 1)))
    return np.array(out)


def linear_propagation(sens: Sensitivities, spec: Spec) -> dict:
    """``linear_std``, ``linear_mean`` and ``linear_share`` per output (module docstring)."""
    var = np.array([t.variance() for t in spec.tolerances])
    mu = np.array([t.mean() for t in spec.tolerances])
    out: dict[str, dict] = {"linear_std": {}, "linear_mean": {}, "linear_share": {}}
    for name, per_key in sens.values.items():
        g = np.array([per_key[k] for k in spec.keys])
        terms = g**2 * var
        total = float(terms.sum())
        out["linear_std"][name] = math.sqrt(total)
        out["linear_mean"][name] = sens.nominal_outputs[name] + float(g @ mu)
        out["linear_share"][name] = {k: (float(t / total) if total > 0 else float("nan"))
                                     for k, t in zip(spec.keys, terms)}
    return out


def round_off_outputs(nominal: dict[str, float], samples: dict[str, np.ndarray] | None,
                      groups: Mapping[str, tuple[str, ...]] = LOAD_GROUPS) -> dict[str, float]:
    """The structurally zero outputs (module docstring) and their round-off level: the largest value of each
    over the nominal design and the sampled ones that assemble fully (``samples``: every output ``(n,)``
    and ``status``; ``None``: the nominal design only); ``groups``: the loads' unit groups (the slider
    crank's :data:`~dualmech.models.tolerance.outputs.LOAD_GROUPS`, or a table kind's)."""
    designs = {name: np.array([value]) for name, value in nominal.items()}
    if samples is not None:
        ok = np.asarray(samples["status"], dtype=str) == DesignStatus.OK.value
        designs = {name: np.append(v, np.asarray(samples[name], float)[ok]) for name, v in designs.items()}
    out = {}
    for group in groups.values():
        names = [n for n in group if n in designs]
        if not names:
            continue
        scale = np.nanmax(np.stack([designs[n] for n in names]), axis=0)
        for n in names:
            value = designs[n]
            if np.all(np.isfinite(value) & (value <= ROUND_OFF_RELATIVE.value * scale)):
                out[n] = float(value.max())
    return out


#: Largest spread of a constant output, relative to its magnitude (module docstring): 10^4 eps.  A constant
#: load (the given drive torque as joint 1's moment, 100 lbf·in) spreads by 1-3 eps over sampled designs;
#: a histogram needs distinct bin edges, which ``np.histogram`` cannot make below ~50 eps (its 50 bins).
CONSTANT_RELATIVE = 1e4 * float(np.finfo(float).eps)


def constant_outputs(nominal: dict[str, float], samples: dict[str, np.ndarray] | None,
                     skip: dict[str, float]) -> dict[str, float]:
    """The constant outputs (module docstring) but those in ``skip``, with their spread (max - min) over the
    nominal design and the sampled ones that assemble fully; none without ``samples``."""
    if samples is None:
        return {}
    ok = np.asarray(samples["status"], dtype=str) == DesignStatus.OK.value
    out = {}
    for name, y0 in nominal.items():
        values = np.append(y0, np.asarray(samples[name], float)[ok])
        if name in skip or not np.all(np.isfinite(values)):
            continue
        spread, scale = float(values.max() - values.min()), float(np.abs(values).max())
        if scale > 0 and spread <= CONSTANT_RELATIVE * scale:
            out[name] = spread
    return out


def _as_zero(out: dict, round_off: dict[str, float], keys: tuple[str, ...], n: int) -> None:
    """Report the round-off outputs of ``out`` (:func:`summarize`'s) as 0, their variance shares as None."""
    zero = describe(np.zeros(n)) if n else None
    for name in round_off:
        out["nominal"][name] = 0.0
        if out["outputs"]:
            out["outputs"][name] = zero
        for part in ("contribution", "linear_share"):
            if out[part] is not None:
                out[part][name] = None
        if out["sensitivity"] is not None:
            out["sensitivity"][name] = dict.fromkeys(keys, 0.0)
            out["linear_std"][name] = out["linear_mean"][name] = 0.0


def summarize(spec: Spec, nominal: dict[str, float], x: np.ndarray | None,
              samples: dict[str, np.ndarray] | None, sens: Sensitivities | None,
              groups: Mapping[str, tuple[str, ...]] = LOAD_GROUPS) -> dict:
    """The statistics of ``summary.json`` (module docstring), without the study's identity fields.

    ``nominal`` are the outputs of the nominal design (their names are the outputs summarised);
    ``x`` ``(n, k)`` sampled key values and ``samples`` (every output and ``status``, ``(n,)``) are
    ``None`` for ``--method linear``; ``sens`` is ``None`` for ``--method mc``; ``groups`` the loads' unit
    groups (:func:`round_off_outputs`).
    """
    names = tuple(nominal)
    round_off = round_off_outputs(nominal, samples, groups)
    out: dict = {"outputs": {}, "yield": None, "sensitivity": None, "sensitivity_positions_deg": None,
                 "linear_std": None, "linear_mean": None, "linear_share": None, "contribution": None,
                 "nominal": dict(nominal), "round_off": round_off}
    n_ok = 0
    if samples is not None and x is not None:
        ok = np.asarray(samples["status"], dtype=str) == DesignStatus.OK.value
        n_ok = int(ok.sum())
        out["outputs"] = {name: describe(samples[name][ok]) for name in names}
        out["yield"] = wilson(int(ok.sum()), int(ok.size))
        sobol = {name: sobol_first_order(x[ok], samples[name][ok]) for name in names}
        out["contribution"] = {name: dict(zip(spec.keys, map(float, s))) for name, s in sobol.items()}
    if sens is not None:
        lin = linear_propagation(sens, spec)
        out.update(sensitivity={n: dict(v) for n, v in sens.values.items()},
                   sensitivity_positions_deg=sens.positions_deg, **lin)
    _as_zero(out, round_off, spec.keys, n_ok)
    out["constant"] = constant_outputs(nominal, samples, round_off)
    for part in ("contribution", "linear_share"):
        if out[part] is not None:
            out[part].update(dict.fromkeys(out["constant"]))
    return out
