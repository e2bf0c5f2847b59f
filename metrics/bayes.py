"""Hierarchical Beta model of per-view recall (or precision), sampled with emcee.

DESIGN.md, "Uncertainty": a Bayesian model of how the occluder's quality
varies between views, beside the bootstrap of the pooled figure. Within one
view the Q quads are independent draws, so the quad tallies of
:class:`metrics.QuadCounts` are binomial: of the n_i quads that the original
fully occludes, k_i are also fully occluded by the occluder (recall; for
precision, of the quads the occluder occludes, those the original occludes
too). Each view has its own rate theta_i, and the views are a sample from a
population:

    k_i | theta_i ~ Binomial(n_i, theta_i)
    theta_i ~ Beta(mu phi, (1 - mu) phi)
    mu ~ Uniform(0, 1),  log phi ~ Normal(log 20, 3)

theta_i is integrated out analytically (beta-binomial likelihood), so the
sampler explores (logit mu, log phi) only: the hierarchical model of Gelman
et al., Bayesian Data Analysis, 3rd ed., sec. 5.3, with a proper weak prior
on the concentration phi (the uniform-in-mu, phi^-5/2 prior of that section
is improper when every view is perfect). Reported: the population mean mu,
the between-view standard deviation sqrt(mu (1 - mu) / (1 + phi)), and the
share of views whose rate is below a threshold, with emcee's acceptance
fraction, integrated autocorrelation time and effective sample size
(Foreman-Mackey et al. 2013, PASP 125:306).

The rates are per quad (each quad weighs one), unlike the pooled pixel-
weighted precision and recall, which weigh quads by their pixels.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy import special, stats

from viscore import InputError
from viscore._validate import as_fraction, as_positive_int

from .precision_recall import PrecisionRecall

__all__ = ["BetaModelSummary", "hierarchical_beta_model"]

_log = logging.getLogger(__name__)

#: Prior of log phi: Normal(log 20, 3) (a prior between-view s.d. from ~0 to ~0.5).
_LOG_PHI_PRIOR = (np.log(20.0), 3.0)

#: emcee's advice: trust tau only when the chain is longer than 50 tau.
_MIN_STEPS_PER_TAU = 50

#: Acceptance fractions outside this range suggest a badly tuned ensemble.
_ACCEPTANCE_RANGE = (0.15, 0.8)


@dataclass(frozen=True)
class BetaModelSummary:
    """Posterior summary of the hierarchical Beta model of one quantity.

    Attributes
    ----------
    quantity : {'recall', 'precision'}
    views_used : int
        Views with at least one informative quad.
    mean, mean_ci : float, list of 2 float
        Population mean mu: posterior mean and 95% credible interval.
    spread, spread_ci : float, list of 2 float
        Between-view standard deviation of the rate.
    threshold : float
    tail_probability, tail_probability_ci : float, list of 2 float
        Share of views (in the population) whose rate is below ``threshold``.
    acceptance_fraction : float
        Mean over walkers.
    autocorr_time : list of 2 float
        Integrated autocorrelation time of logit mu and log phi, in steps.
    effective_samples : float
        walkers x kept steps / max autocorrelation time.
    converged : bool
        False when a warning below applies.
    warnings : list of str
    walkers, steps, burn, seed : int
    """

    quantity: str
    views_used: int
    mean: float
    mean_ci: list
    spread: float
    spread_ci: list
    threshold: float
    tail_probability: float
    tail_probability_ci: list
    acceptance_fraction: float
    autocorr_time: list
    effective_samples: float
    converged: bool
    warnings: list
    walkers: int
    steps: int
    burn: int
    seed: int


def _counts(result: PrecisionRecall, quantity: str) -> tuple[np.ndarray, np.ndarray]:
    pv = result.per_view
    if "quads_both" not in pv:
        raise InputError("result: has no quad tallies (evaluate with this version of viscore)")
    k = np.asarray(pv["quads_both"], dtype=np.float64)
    n = np.asarray(pv["quads_orig" if quantity == "recall" else "quads_occ"], dtype=np.float64)
    keep = n > 0
    return k[keep], n[keep]


def _log_posterior(theta: np.ndarray, k: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Vectorised over walkers: theta is (w, 2) = (logit mu, log phi)."""
    logit_mu, log_phi = theta[:, 0], theta[:, 1]
    out = np.full(len(theta), -np.inf)
    ok = (np.abs(logit_mu) < 30) & (log_phi > -10) & (log_phi < 30)
    if not ok.any():
        return out
    mu = special.expit(logit_mu[ok])
    phi = np.exp(log_phi[ok])
    a, b = (mu * phi)[:, None], ((1 - mu) * phi)[:, None]
    loglik = (special.betaln(k + a, n - k + b) - special.betaln(a, b)).sum(axis=1)
    prior = (np.log(mu) + np.log1p(-mu)  # uniform mu, Jacobian of the logit
             + stats.norm.logpdf(log_phi[ok], *_LOG_PHI_PRIOR))
    out[ok] = loglik + prior
    return out


def hierarchical_beta_model(result: PrecisionRecall, *, quantity: str = "recall",
                            threshold: float = 0.9, walkers: int = 32, steps: int = 4000,
                            burn: int | None = None, seed: int = 0) -> BetaModelSummary:
    """Sample the hierarchical Beta model of per-view recall or precision.

    Parameters
    ----------
    result : PrecisionRecall
        An orbit or volume evaluation (its per-view quad tallies are used).
    quantity : {'recall', 'precision'}, optional
    threshold : float, optional
        For the tail probability P(theta < threshold). Default 0.9.
    walkers : int, optional
        emcee walkers, at least 4. Default 32.
    steps : int, optional
        Steps per walker, default 4000 (about 100 autocorrelation times on
        typical inputs).
    burn : int, optional
        Steps discarded; default a quarter of ``steps``.
    seed : int, optional
        Seeds the initial ensemble and emcee's generator. Default 0.

    Returns
    -------
    BetaModelSummary

    Raises
    ------
    InputError
        On a bad quantity or sizes, or fewer than two informative views.

    Notes
    -----
    Deterministic given ``seed``. A warning (logged and in the summary)
    says when the chain is shorter than 50 autocorrelation times or the
    acceptance fraction is unusual; then ``converged`` is False and the
    figures should not be trusted: run more ``steps``.
    """
    import emcee

    if quantity not in ("recall", "precision"):
        raise InputError(f"quantity: expected 'recall' or 'precision', got {quantity!r}")
    threshold = as_fraction(threshold, "threshold")
    walkers = as_positive_int(walkers, "walkers")
    if walkers < 4:
        raise InputError(f"walkers: at least 4 (twice the 2 parameters), got {walkers}")
    steps = as_positive_int(steps, "steps")
    burn = steps // 4 if burn is None else int(burn)
    if not 0 <= burn < steps:
        raise InputError(f"burn: expected 0 <= burn < steps, got {burn}")
    k, n = _counts(result, quantity)
    if len(k) < 2:
        raise InputError(f"result: fewer than two views inform the {quantity}")
    rng = np.random.default_rng(seed)
    rates = (k + 0.5) / (n + 1.0)
    mu0 = float(np.clip(rates.mean(), 0.02, 0.98))
    var = float(rates.var()) or 1e-4
    phi0 = float(np.clip(mu0 * (1 - mu0) / var - 1, 1.0, 1e6))
    start = np.array([special.logit(mu0), np.log(phi0)]) + 0.05 * rng.normal(size=(walkers, 2))
    sampler = emcee.EnsembleSampler(walkers, 2, _log_posterior, args=(k, n), vectorize=True)
    sampler.random_state = np.random.RandomState(seed).get_state()
    sampler.run_mcmc(start, steps, progress=False)
    chain = sampler.get_chain(discard=burn, flat=True)
    tau = np.asarray(sampler.get_autocorr_time(discard=burn, tol=0), dtype=np.float64)
    acceptance = float(np.mean(sampler.acceptance_fraction))
    kept = steps - burn
    ess = float(walkers * kept / max(tau.max(), 1.0))
    warnings = []
    if kept < _MIN_STEPS_PER_TAU * tau.max():
        warnings.append(f"chain too short: {kept} kept steps < {_MIN_STEPS_PER_TAU} x "
                        f"autocorrelation time {tau.max():.1f}; run more steps")
    if not _ACCEPTANCE_RANGE[0] <= acceptance <= _ACCEPTANCE_RANGE[1]:
        warnings.append(f"acceptance fraction {acceptance:.2f} outside "
                        f"{_ACCEPTANCE_RANGE[0]}-{_ACCEPTANCE_RANGE[1]}")
    for w in warnings:
        _log.warning("hierarchical Beta model (%s): %s", quantity, w)
    mu = special.expit(chain[:, 0])
    phi = np.exp(chain[:, 1])
    spread = np.sqrt(mu * (1 - mu) / (1 + phi))
    tail = stats.beta.cdf(threshold, mu * phi, (1 - mu) * phi)

    def ci(x):
        return [float(np.quantile(x, 0.025)), float(np.quantile(x, 0.975))]

    return BetaModelSummary(
        quantity=quantity, views_used=len(k), mean=float(mu.mean()), mean_ci=ci(mu),
        spread=float(spread.mean()), spread_ci=ci(spread), threshold=threshold,
        tail_probability=float(tail.mean()), tail_probability_ci=ci(tail),
        acceptance_fraction=acceptance, autocorr_time=tau.tolist(), effective_samples=ess,
        converged=not warnings, warnings=warnings, walkers=walkers, steps=steps, burn=burn,
        seed=seed)
