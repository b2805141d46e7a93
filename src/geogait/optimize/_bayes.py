r"""The measured climb's third rule: trust-region Bayesian optimisation on measured outcomes.

A Gaussian process (Matérn 5/2 kernel, one length scale per coordinate, hyper-parameters by the largest
marginal likelihood; Rasmussen & Williams, *Gaussian Processes for Machine Learning*, 2006, eqs. 4.17 and
5.8) models the measured objective over the search's coordinates from **every** point measured so far,
wherever it lies. Each candidate maximises the expected improvement over the best measured value (Jones,
Schonlau & Welch, J. Global Optim. 13, 1998), times the probability that its net rotation per cycle keeps
the climb's limit where the family can turn (a second process on the measured rotations; Gardner et al.,
ICML 2014), inside a box around the best point measured (TuRBO: Eriksson et al., NeurIPS 2019): its
half-width, scaled per coordinate by the length scales, doubles after three candidates in a row that
improve on the best and halves after ``max(4, n / 2)`` in a row that do not; the search has converged below
its final half-width.

Why here: COBYQA (:mod:`._search`) begins with a fixed design of 2n + 1 probes, one coordinate at a time,
before its first model step — 2(2n + 1) robot cycles with a settling cycle per candidate, 42 on a
10-parameter gait. The process needs no design: from the second candidate on, every point it has measured
shapes the next one, which moves every parameter at once.

The search is a function of its history: :meth:`BayesianSearch.ask` fits the processes afresh and draws
its random candidates from a generator seeded by the search's seed and the number of values told, so a
search restored from a checkpoint proposes exactly what the original would have.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import cho_solve, solve_triangular
from scipy.optimize import minimize
from scipy.special import ndtr

from ._search import MeasuredSearch

__all__ = ["BayesianSearch", "GaussianProcess"]

_ROOT5 = np.sqrt(5.0)
_PRIOR_WIDTH = 1.5  # log-normal prior on each length scale, centred on twice the search's first half-width


class GaussianProcess:
    """Gaussian-process regression with a constant mean and a Matérn 5/2 kernel with one length scale per
    coordinate: k(x, x') = σ_f² (1 + √5 r + 5r²/3) exp(−√5 r), r² = Σᵢ (xᵢ − x'ᵢ)² / ℓᵢ², plus noise σ_n².

    Parameters
    ----------
    scale : float
        Typical distance between the points (coordinates' units): the length scales' prior is centred
        on ``2 · scale`` and bounded to [0.05, 50] · scale.
    """

    def __init__(self, scale: float):
        self.scale = float(scale)

    @staticmethod
    def _kernel(a, b, length_scales, signal):
        difference = (a[:, None, :] - b[None, :, :]) / length_scales
        r = np.sqrt((difference ** 2).sum(-1))
        return signal * (1 + _ROOT5 * r + 5 / 3 * r ** 2) * np.exp(-_ROOT5 * r), difference, r

    def _negative_log_evidence(self, theta, x, y):
        """−log p(y | x, θ) (eq. 5.8) plus the length scales' log-normal prior, and its gradient in θ =
        (log ℓ, log σ_f², log σ_n²)."""
        d = x.shape[1]
        length_scales, signal, noise = np.exp(theta[:d]), np.exp(theta[d]), np.exp(theta[d + 1])
        kernel, difference, r = self._kernel(x, x, length_scales, signal)
        try:
            factor = np.linalg.cholesky(kernel + (noise + 1e-8) * np.eye(len(y)))
        except np.linalg.LinAlgError:
            return np.inf, np.zeros_like(theta)
        alpha = cho_solve((factor, True), y)
        inner = np.outer(alpha, alpha) - cho_solve((factor, True), np.eye(len(y)))
        # ∂K/∂log ℓᵢ = σ_f² (5/3)(1 + √5 r) exp(−√5 r) (Δᵢ/ℓᵢ)²
        radial = signal * 5 / 3 * (1 + _ROOT5 * r) * np.exp(-_ROOT5 * r)
        gradient = np.empty_like(theta)
        gradient[:d] = -0.5 * np.einsum("jk,jk,jki->i", inner, radial, difference ** 2)
        gradient[d] = -0.5 * np.sum(inner * kernel)
        gradient[d + 1] = -0.5 * np.trace(inner) * noise
        centred = (theta[:d] - np.log(2 * self.scale)) / _PRIOR_WIDTH
        gradient[:d] += centred / _PRIOR_WIDTH
        value = 0.5 * y @ alpha + np.log(np.diag(factor)).sum() + 0.5 * centred @ centred
        return value, gradient

    def fit(self, x, y) -> GaussianProcess:
        """Condition on the values ``y`` measured at the points ``x`` (shape (m, d)); with three or more, the
        hyper-parameters of the largest evidence first."""
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        d = x.shape[1]
        self.x_, self.mean_ = x, float(y.mean())
        spread = float(y.std())
        self.std_ = spread if spread > 0 else max(abs(self.mean_), 1e-12)
        standard = (y - self.mean_) / self.std_
        theta = np.r_[np.full(d, np.log(2 * self.scale)), 0.0, np.log(1e-3)]
        if len(y) >= 3:
            low = np.r_[np.full(d, np.log(0.05 * self.scale)), np.log(0.05), np.log(1e-6)]
            high = np.r_[np.full(d, np.log(50 * self.scale)), np.log(20.0), np.log(0.3)]
            theta = minimize(self._negative_log_evidence, theta, args=(x, standard), jac=True, method="L-BFGS-B",
                             bounds=list(zip(low, high, strict=True)), options={"maxiter": 100}).x
        self.length_scales_, self.signal_, self.noise_ = np.exp(theta[:d]), np.exp(theta[d]), np.exp(theta[d + 1])
        kernel = self._kernel(x, x, self.length_scales_, self.signal_)[0]
        self.factor_ = np.linalg.cholesky(kernel + (self.noise_ + 1e-8) * np.eye(len(y)))
        self.alpha_ = cho_solve((self.factor_, True), standard)
        return self

    def predict(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Posterior mean and standard deviation of the noise-free value at ``points`` (shape (k, d))."""
        cross = self._kernel(np.atleast_2d(points), self.x_, self.length_scales_, self.signal_)[0]
        mean = cross @ self.alpha_
        v = solve_triangular(self.factor_, cross.T, lower=True)
        variance = np.maximum(self.signal_ - (v ** 2).sum(0), 1e-12)
        return self.mean_ + self.std_ * mean, self.std_ * np.sqrt(variance)


def _expected_improvement(mean, std, best):
    z = (mean - best) / std
    return (mean - best) * ndtr(z) + std * np.exp(-0.5 * z ** 2) / np.sqrt(2 * np.pi)


@dataclass
class BayesianSearch(MeasuredSearch):
    """Trust-region Bayesian optimisation from ``origin``, as the values measured so far (module docstring);
    parameters as :class:`~geogait.optimize._search.MeasuredSearch` (``radius``: the box's first half-width;
    ``final_radius``: the half-width below which the search has converged), and

    seed : int
        Seed of the random candidates (with the number of values told).
    """

    seed: int = 0
    _converged: bool = field(default=False, init=False, repr=False, compare=False)

    rule = "bayes"
    _checkpointed = ("seed",)
    #: Random candidates scored per proposal (uniform in the box); the best-scored whose neighbourhoods are searched,
    #: and those neighbourhoods' widths (share of the box).
    CANDIDATES = 1000
    LEADERS = 10
    REFINE = (0.1, 0.03, 0.01)

    def half_width(self) -> float:
        """The box's half-width after the values told (TuRBO's rule, module docstring)."""
        width, successes, failures = self.radius, 0, 0
        patience = max(4, self.origin.size // 2)
        best = self.values[0] if self.values else np.nan
        for value in self.values[1:]:
            if value > best + 1e-3 * abs(best):
                successes, failures = successes + 1, 0
            else:
                successes, failures = 0, failures + 1
            best = max(best, value)
            if successes == 3:
                width, successes = min(2 * width, 4 * self.radius), 0
            if failures == patience:
                width, failures = width / 2, 0
        return width

    @property
    def converged(self) -> bool:
        """The box shrank below its final half-width, or holds no point within the known limits."""
        return self._converged

    def ask(self, bounds=None, known=None, rotation_limit: float | None = None, rng=None) -> np.ndarray | None:
        """The next point to measure, or None when the search has converged; arguments as
        :meth:`~geogait.optimize._search.MeasuredSearch.ask` (``rng`` unused: the search draws from its own
        seed)."""
        if not self.values:
            return self.origin.copy()
        width = self.half_width()
        if width < self.final_radius:
            self._converged = True
            return None
        x, y = np.asarray(self.points), np.asarray(self.values)
        objective = GaussianProcess(self.radius).fit(x, y)
        rotation = None if rotation_limit is None else GaussianProcess(self.radius).fit(x, self.rotations)
        best_point, best = x[np.argmax(y)], float(y.max())
        half = width * objective.length_scales_ / np.exp(np.log(objective.length_scales_).mean())
        low, high = best_point - half, best_point + half
        if bounds is not None:
            box = np.asarray([(-np.inf, np.inf) if b is None else b for b in bounds], dtype=float)
            low, high = np.maximum(low, box[:, 0]), np.minimum(high, box[:, 1])

        def score(z):
            mean, std = objective.predict(z)
            value = _expected_improvement(mean, std, best)
            if rotation is not None:
                turn, spread = rotation.predict(z)
                value = value * (ndtr((rotation_limit - turn) / spread) - ndtr((-rotation_limit - turn) / spread))
            return value

        def best_feasible(points, count):  # the best-scored points that keep the known limits
            chosen = []
            for point in points[np.argsort(-score(points))]:
                if known is None or np.all(np.asarray(known(point)) <= 0):
                    chosen.append(point)
                    if len(chosen) == count:
                        break
            return np.reshape(chosen, (-1, self.origin.size))

        # candidates: uniform in the box, then near the best-scored ones at shrinking distances (a vectorised
        # local search for the acquisition's maximum)
        rng = np.random.default_rng([self.seed, len(self.values)])
        candidates = low + (high - low) * rng.random((self.CANDIDATES, self.origin.size))
        for spread in self.REFINE:
            leaders = best_feasible(candidates, self.LEADERS)
            if not len(leaders):
                self._converged = True  # nothing feasible left in the box
                return None
            near = np.repeat(leaders, self.CANDIDATES // (2 * self.LEADERS), axis=0)
            near = np.clip(near + spread * (high - low) * rng.standard_normal(near.shape), low, high)
            candidates = np.concatenate([leaders, near])
        return best_feasible(candidates, 1)[0]
