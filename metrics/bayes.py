"""Hierarchical Beta model of per-view recall (or precision), sampled with emcee.

The hierarchical model of Gelman et al. 2013, sec. 5.3, with a beta-binomial
likelihood and a weak prior on the concentration, sampled by emcee.

References
----------
.. [1] Gelman, A., Carlin, J. B., Stern, H. S., Dunson, D. B., Vehtari, A.,
   Rubin, D. B. "Bayesian Data Analysis", 3rd ed. CRC Press, 2013, sec. 5.3.
   :DOI:`10.1201/b16018`
.. [2] Foreman-Mackey, D., Hogg, D. W., Lang, D., Goodman, J. "emcee: The MCMC
   Hammer". Publications of the Astronomical Society of the Pacific 125(925),
   2013, pp. 306-312. :DOI:`10.1086/670067`
.. [3] Goodman, J., Weare, J. "Ensemble samplers with affine invariance".
   Communications in Applied Mathematics and Computational Science 5(1), 2010,
   pp. 65-80. :DOI:`10.2140/camcos.2010.5.65`
.. [4] Savitsky, T. D., Toth, D. "Bayesian estimation under informative
   sampling". Electronic Journal of Statistics 10(1), 2016, pp. 1677-1708.
   :DOI:`10.1214/16-EJS1153`
.. [5] Wu, K., He, X., Pan, Z., Gao, X. "Occluder Generation for Buildings in
   Digital Games". Computer Graphics Forum 41(7), 2022, pp. 205-214.
   :DOI:`10.1111/cgf.14669`
"""

from __future__ import annotations

import logging
import numbers
from dataclasses import dataclass

import numpy as np
from scipy import special, stats

from viscore import InputError
from viscore._validate import as_fraction, as_positive_int, as_seed, check_memory

from .precision_recall import PrecisionRecall
from .reference_views import check_protocol

__all__ = ["BetaModelSummary", "hierarchical_beta_model", "check_model_memory",
           "BAYES_QUANTITIES"]

_log = logging.getLogger(__name__)

#: Quantities the model describes.
BAYES_QUANTITIES = ("recall", "precision")

#: Prior of log phi: Normal(log 20, 3) (a prior between-view s.d. from ~0 to ~0.5).
_LOG_PHI_PRIOR = (np.log(20.0), 3.0)

#: Normalising constant of that prior's log density, log(3 sqrt(2 pi)).
_LOG_PHI_NORM = float(np.log(_LOG_PHI_PRIOR[1] * np.sqrt(2.0 * np.pi)))

#: emcee's advice: trust tau only when the chain is longer than 50 tau.
_MIN_STEPS_PER_TAU = 50

#: Acceptance fractions outside this range suggest a badly tuned ensemble.
_ACCEPTANCE_RANGE = (0.15, 0.8)

#: Bytes per walker-step: emcee's stored chain (2 float64) and log-probability,
#: the flattened chain and its autocorrelation copy, and the derived mu, phi,
#: spread and tail arrays.
_BYTES_PER_WALKER_STEP = 88

#: Bytes per walker and distinct (k, n) tally in one vectorised log-posterior
#: (about six float64 temporaries).
_BYTES_PER_WALKER_TALLY = 48

#: Bytes per view while the tallies are read, weighted and grouped.
_BYTES_PER_VIEW = 96


def check_model_memory(*, walkers: int, steps: int, views: int) -> None:
    """Refuse a model fit whose memory would not fit, before any work.

    Parameters
    ----------
    walkers, steps : int
        Of the emcee run.
    views : int
        Views of the evaluation (an upper bound of its distinct tallies).

    Raises
    ------
    InputError
        When walkers x steps and walkers x views need more than the memory
        limit of :func:`viscore._validate.check_memory`.
    """
    nbytes = (float(_BYTES_PER_WALKER_STEP) * walkers * steps
              + float(_BYTES_PER_WALKER_TALLY) * walkers * views
              + float(_BYTES_PER_VIEW) * views)
    check_memory(nbytes, f"Beta model of {views} views, {walkers} walkers x {steps} steps")


@dataclass(frozen=True)
class BetaModelSummary:
    """Posterior summary of the hierarchical Beta model of one quantity.

    Attributes
    ----------
    quantity : {'recall', 'precision'}
    views_used : int
        Views with at least one informative quad and a positive weight.
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
    weighted : bool
        True when the views used had unequal weights (``per_view["weight"]``).
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
    weighted: bool = False


def _tallies(result: PrecisionRecall, quantity: str
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, bool]:
    """Distinct (k, n) tallies of the informative views, with their summed weights.

    Returns ``k``, ``n`` and ``w`` (one entry per distinct tally; ``w`` sums
    the views' weights normalised to a total of ``used``), ``used`` (views
    with n > 0 and weight > 0) and whether those weights were unequal.
    """
    pv = result.per_view
    if "quads_both" not in pv:
        raise InputError("result: has no quad tallies (evaluate with this version of viscore)")
    k = np.asarray(pv["quads_both"], dtype=np.float64)
    n = np.asarray(pv["quads_orig" if quantity == "recall" else "quads_occ"], dtype=np.float64)
    if "weight" in pv:
        w = np.asarray(pv["weight"], dtype=np.float64)
    elif result.protocol == "orbit":  # orbit views weigh one each
        w = np.ones_like(k)
    else:
        raise InputError("result: per-view weights are missing (per_view['weight'])")
    if not k.shape == n.shape == w.shape or k.ndim != 1:
        raise InputError(f"result: per-view tallies and weights differ in shape "
                         f"({k.shape}, {n.shape}, {w.shape})")
    if not (np.isfinite(w).all() and (w >= 0).all()):
        raise InputError("result: per-view weights must be finite and non-negative")
    keep = (n > 0) & (w > 0)
    k, n, w = k[keep], n[keep], w[keep]
    used = len(k)
    weighted = bool(used and w.max() > w.min())
    if used:
        w = w * (used / w.sum())
    pairs, inverse = np.unique(np.stack([k, n], axis=1), axis=0, return_inverse=True)
    weights = np.bincount(inverse.reshape(-1), weights=w, minlength=len(pairs))
    return pairs[:, 0], pairs[:, 1], weights, used, weighted


def _log_posterior(theta: np.ndarray, k: np.ndarray, n: np.ndarray, w: np.ndarray
                   ) -> np.ndarray:
    """Vectorised over walkers: ``theta`` is (walkers, 2) = (logit mu, log phi).

    ``k``, ``n``: (m,) distinct tallies; ``w``: (m,) their summed view weights.
    """
    logit_mu, log_phi = theta[:, 0], theta[:, 1]
    out = np.full(len(theta), -np.inf)
    ok = (np.abs(logit_mu) < 30) & (log_phi > -10) & (log_phi < 30)
    if not ok.any():
        return out
    mu = special.expit(logit_mu[ok])
    phi = np.exp(log_phi[ok])
    a, b = (mu * phi)[:, None], ((1 - mu) * phi)[:, None]
    loglik = ((special.betaln(k + a, n - k + b) - special.betaln(a, b)) @ w)
    z = (log_phi[ok] - _LOG_PHI_PRIOR[0]) / _LOG_PHI_PRIOR[1]
    prior = (np.log(mu) + np.log1p(-mu)  # uniform mu, Jacobian of the logit
             - 0.5 * z * z - _LOG_PHI_NORM)  # log phi ~ Normal(log 20, 3)
    out[ok] = loglik + prior
    return out


def hierarchical_beta_model(result: PrecisionRecall, *, quantity: str = "recall",
                            threshold: float = 0.9, walkers: int = 32, steps: int = 4000,
                            burn: int | None = None, seed: int = 0) -> BetaModelSummary:
    """Sample the hierarchical Beta model of per-view recall or precision.

    Parameters
    ----------
    result : PrecisionRecall
        An orbit or volume evaluation (its per-view quad tallies and weights
        are used).
    quantity : {'recall', 'precision'}, optional
        Default 'recall'.
    threshold : float, optional
        For the tail probability P(theta < threshold), in [0, 1]. Default 0.9.
    walkers : int, optional
        emcee walkers, at least 4. Default 32.
    steps : int, optional
        Steps per walker, default 4000 (about 100 autocorrelation times on
        typical inputs).
    burn : int, optional
        Steps discarded, 0 <= burn < steps; default a quarter of ``steps``.
    seed : int, optional
        Non-negative integer of any size (see Notes). Default 0.

    Returns
    -------
    BetaModelSummary

    Raises
    ------
    InputError
        On a bad quantity, size, seed or weight, a result of an unknown
        protocol, fewer than two informative views, or a fit whose memory
        (walkers x steps, walkers x views) would not fit.

    Notes
    -----
    Deterministic given ``seed``: ``numpy.random.SeedSequence(seed)`` spawns
    two children. The first seeds ``numpy.random.default_rng`` for the
    initial ensemble; the second seeds an MT19937 bit generator whose
    ``RandomState`` state is handed to emcee (emcee 3 draws from a legacy
    ``RandomState`` and does not take a ``Generator``). Seeds beyond 2**32
    therefore work, and distinct seeds give distinct streams.

    Views are weighted by ``per_view["weight"]`` (normalised to sum to the
    number of views used), the weights of the pooled estimate; views of
    weight 0 are left out. A warning (logged and in the summary) says when
    the chain is shorter than 50 autocorrelation times or the acceptance
    fraction is unusual; then ``converged`` is False and the figures should
    not be trusted: run more ``steps``.

    References
    ----------
    .. [1] Gelman, A., Carlin, J. B., Stern, H. S., Dunson, D. B., Vehtari, A.,
       Rubin, D. B. "Bayesian Data Analysis", 3rd ed. CRC Press, 2013, sec. 5.3.
       :DOI:`10.1201/b16018`
    .. [2] Foreman-Mackey, D., Hogg, D. W., Lang, D., Goodman, J. "emcee: The
       MCMC Hammer". Publications of the Astronomical Society of the Pacific
       125(925), 2013, pp. 306-312. :DOI:`10.1086/670067`
    .. [3] Savitsky, T. D., Toth, D. "Bayesian estimation under informative
       sampling". Electronic Journal of Statistics 10(1), 2016, pp. 1677-1708.
       :DOI:`10.1214/16-EJS1153`

    Examples
    --------
    >>> from viscore.metrics import PrecisionRecall
    >>> k = np.array([90, 95, 80, 99]); n = np.full(4, 100)
    >>> pv = {"nt": k, "pf": n - k, "nf": np.zeros(4), "quads_orig": n, "quads_occ": k,
    ...       "quads_both": k, "weight": np.ones(4)}
    >>> r = PrecisionRecall(precision=1.0, recall=0.91, precision_ci=[1, 1],
    ...                     recall_ci=[0, 1], per_view=pv, protocol="orbit",
    ...                     depth_aware=False, seed=0, params={}, seconds=0.0)
    >>> s = hierarchical_beta_model(r, steps=400, walkers=8)
    >>> bool(0.8 < s.mean < 1.0), s.views_used
    (True, 4)
    """
    import emcee

    if quantity not in BAYES_QUANTITIES:
        raise InputError(f"quantity: expected one of {', '.join(BAYES_QUANTITIES)}, "
                         f"got {quantity!r}")
    if not isinstance(result, PrecisionRecall):
        raise InputError(f"result: expected a PrecisionRecall, got {type(result).__name__}")
    check_protocol(result.protocol, "result.protocol")
    threshold = as_fraction(threshold, "threshold")
    walkers = as_positive_int(walkers, "walkers")
    if walkers < 4:
        raise InputError(f"walkers: at least 4 (twice the 2 parameters), got {walkers}")
    steps = as_positive_int(steps, "steps")
    if burn is None:
        burn = steps // 4
    elif isinstance(burn, bool) or not isinstance(burn, numbers.Integral):
        raise InputError(f"burn: expected an integer, got {burn!r}")
    burn = int(burn)
    if not 0 <= burn < steps:
        raise InputError(f"burn: expected 0 <= burn < steps, got {burn}")
    seed = as_seed(seed)
    check_model_memory(walkers=walkers, steps=steps, views=result.views)
    k, n, w, used, weighted = _tallies(result, quantity)
    if used < 2:
        raise InputError(f"result: fewer than two views inform the {quantity}")
    init_seq, emcee_seq = np.random.SeedSequence(seed).spawn(2)
    rng = np.random.default_rng(init_seq)
    rates = (k + 0.5) / (n + 1.0)
    mu0 = float(np.clip(np.average(rates, weights=w), 0.02, 0.98))
    var = float(np.average((rates - mu0) ** 2, weights=w)) or 1e-4
    phi0 = float(np.clip(mu0 * (1 - mu0) / var - 1, 1.0, 1e6))
    start = np.array([special.logit(mu0), np.log(phi0)]) + 0.05 * rng.normal(size=(walkers, 2))
    sampler = emcee.EnsembleSampler(walkers, 2, _log_posterior, args=(k, n, w), vectorize=True)
    state = np.random.RandomState(np.random.MT19937(emcee_seq)).get_state()
    sampler.random_state = state  # emcee's setter fails silently: check that it took
    if not np.array_equal(sampler.random_state[1], state[1]):  # type: ignore[index]
        raise RuntimeError("emcee did not take the generator state")
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
    for text in warnings:
        _log.warning("hierarchical Beta model (%s): %s", quantity, text)
    mu = special.expit(chain[:, 0])
    phi = np.exp(chain[:, 1])
    spread = np.sqrt(mu * (1 - mu) / (1 + phi))
    tail = stats.beta.cdf(threshold, mu * phi, (1 - mu) * phi)

    def ci(x):
        return [float(np.quantile(x, 0.025)), float(np.quantile(x, 0.975))]

    return BetaModelSummary(
        quantity=quantity, views_used=used, mean=float(mu.mean()), mean_ci=ci(mu),
        spread=float(spread.mean()), spread_ci=ci(spread), threshold=threshold,
        tail_probability=float(tail.mean()), tail_probability_ci=ci(tail),
        acceptance_fraction=acceptance, autocorr_time=tau.tolist(), effective_samples=ess,
        converged=not warnings, warnings=warnings, walkers=walkers, steps=steps, burn=burn,
        seed=seed, weighted=weighted)
