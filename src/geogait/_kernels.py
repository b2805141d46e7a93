r"""Compiled kernels (numba) shared by the models and the path follower. The one-sample path: one call
learns one sample of an unbatched :class:`~geogait.models.AdaptiveGaitModel`.

Why a compiled kernel. One sample of the 3-link model is a few hundred flops: find the covering
windows, build ``[1, δ, δ̇, δ⊗δ̇]`` about each window's nominal point, one rank-one RLS update with
forgetting and the trace clamp per covering window (:mod:`geogait.models._rls`), the same for the
phase model, and the online Γ (eq. 6). Written in NumPy that is some 60 calls of about a
microsecond each, whatever the size of the arrays. Restructuring the NumPy
code removes a fraction of the calls, not their fixed cost; a kernel compiled by numba does the
arithmetic in one call (a few microseconds), so the cost is the arithmetic.

The NumPy code stays the reference and the fallback. The kernel follows it operation by operation
(same window test, same formulas in the same order: ``k = Px / (λ + xᵀPx)``,
``P ← (P − s sᵀ) · (1/λ)`` with ``s = Px / √(λ + xᵀPx)``, the clamp ``P ← P · (trace_max / trace P)``;
the a-priori prediction is the mean over the covering windows, Γ's error the Euclidean norm summed as
NumPy sums it). Only the inner products ``Px``, ``xᵀPx`` and ``Wᵀx``, which NumPy hands to BLAS or
to its own unrolled loops, are summed in plain order here, so the two paths agree to rounding
(≈ 1e-16 relative per update, ≤ 2e-13 after 2 000 samples; the tests hold them to 1e-12), not bit
for bit: BLAS's order depends on the CPU it runs on, so no fixed order could match it everywhere.
The batched paths (``fit``, a ``partial_fit`` of many samples or trials) always use NumPy.

More kernels serve the path-following loop, where the same small computation runs thousands of
times per cycle: the net motion per cycle of a candidate gait under one model, with its Jacobian
(what every steering solve evaluates: :func:`_displacement` for the window model, following
:func:`geogait.models._displacement.displacement_from_terms`, and :func:`_shape_space_displacement`
for :class:`~geogait.models.ShapeSpaceModel`, both ending in the Magnus integration of
:func:`_integrate`; they agree with the NumPy code to rounding, tested to 1e-12), and the
nearest-segment search of :meth:`geogait.control.ReferencePath.project` for the planner's many
horizon positions (:func:`_nearest_segment`: element-wise arithmetic only, so the same
bits as NumPy). Both fall back to the NumPy code as the one-sample kernel does.

numba is optional (``pip install geogait[fast]``). Without it, or with :data:`ENABLED` set to
False, every sample goes through the NumPy reference path, an order of magnitude slower one sample at a time;
:func:`fast_path_note` says so in one line. The kernel is compiled on first use and cached on disk
(``cache=True``): the first process after an install pays the compile, later ones load it
(:func:`warm_up` does that before a stream's first sample).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["ENABLED", "displacement_kernel", "fast_path_available", "fast_path_note", "learn_one_kernel",
           "nearest_segment_kernel", "shape_space_kernel", "warm_up"]

#: Use the compiled one-sample path when numba is installed (set to False to force the NumPy reference).
ENABLED = True

_kernel = None  # the compiled kernel, built on first use
_kernels_loaded = {}  # name -> the path-following kernels, loaded on first use (None: not available)
_missing = None  # why numba could not be used (None: not tried yet or available)


def _learn_one(phase, shape, rate, velocity, scale, max_phase, max_magnitude, check_degrees,
               centres, half_width, nominal, nominal_rate, interaction,
               weights, covariance, n_updates, lam, max_trace,
               base_weights, base_covariance, base_n_updates, base_lam, base_max_trace,
               psi, gamma_lam, out):
    """Learn one sample; returns 0, or 1 (nothing changed) when the reference path must take it.

    ``rate`` is the raw shape velocity (divided by ``scale`` here, as the reference does before its
    update); ``out`` ``(8,)`` receives the a-priori prediction (3), the new ψ (2), the online Γ and
    the baseline's prediction (the last slot is unused).
    """
    d = shape.shape[0]
    # -- the input checks of check_samples (and the degrees warning): anything odd goes the slow way
    if not abs(phase) <= max_phase:
        return 1
    for j in range(d):
        if not (abs(shape[j]) <= max_magnitude and abs(rate[j]) <= max_magnitude):
            return 1
        if check_degrees and abs(shape[j]) > 2 * math.pi:
            return 1
    for k in range(3):
        if not abs(velocity[k]) <= max_magnitude:
            return 1
    n_windows = centres.shape[0]
    n = weights.shape[1]
    two_pi = 2 * math.pi
    x = np.empty(n)
    px = np.empty(n)
    prior_sum = np.zeros(3)
    base_sum = np.zeros(3)
    target = np.empty(3)
    for k in range(3):
        target[k] = velocity[k] / scale
    inv_lam = 1 / lam
    base_inv_lam = 1 / base_lam
    count = 0
    for m in range(n_windows):
        distance = (phase - centres[m] + math.pi) % two_pi - math.pi
        if not abs(distance) <= half_width:
            continue
        count += 1
        # -- regressors about window m's nominal point (eq. 3)
        x[0] = 1.0
        for j in range(d):
            x[1 + j] = shape[j] - nominal[m, j]
            x[1 + d + j] = rate[j] / scale - nominal_rate[m, j]
        if interaction:
            for i in range(d):
                for j in range(d):
                    x[1 + 2 * d + i * d + j] = x[1 + i] * x[1 + d + j]
        # -- rank-one RLS update with forgetting and the trace clamp (RLSBank._step)
        P = covariance[m]
        W = weights[m]
        # Px, summed over j in order for every i; P is exactly symmetric (the update keeps it so), so
        # walking its rows j (contiguous, vectorised across i) gives the same sums as (P x)_i = Σ_j P_ij x_j
        for i in range(n):
            px[i] = 0.0
        for j in range(n):
            xj = x[j]
            for i in range(n):
                px[i] += P[j, i] * xj
        denominator = 0.0
        for i in range(n):
            denominator += x[i] * px[i]
        denominator = lam + denominator
        for k in range(3):
            acc = 0.0
            for i in range(n):
                acc += W[i, k] * x[i]
            prior_sum[k] += acc
            error = target[k] - acc
            for i in range(n):
                W[i, k] += (px[i] / denominator) * error
        root = 1 / math.sqrt(denominator)
        for i in range(n):
            px[i] = px[i] * root
        for i in range(n):
            si = px[i]
            for j in range(n):
                P[i, j] = (P[i, j] - si * px[j]) * inv_lam
        trace = 0.0
        for i in range(n):
            trace += P[i, i]
        if trace > max_trace:
            factor = max_trace / trace
            for i in range(n):
                for j in range(n):
                    P[i, j] *= factor
        n_updates[m] += 1
        # -- the phase model: one regressor (x = 1), the same update
        b = base_covariance[m, 0, 0]
        base_denominator = base_lam + b
        gain = b / base_denominator
        for k in range(3):
            value = base_weights[m, 0, k]
            base_sum[k] += value
            base_weights[m, 0, k] = value + gain * (velocity[k] - value)
        s = b * (1 / math.sqrt(base_denominator))
        b = (b - s * s) * base_inv_lam
        if b > base_max_trace:
            b = b * (base_max_trace / b)
        base_covariance[m, 0, 0] = b
        base_n_updates[m] += 1
    # -- a-priori predictions (mean over the covering windows) and the online Γ (eq. 6)
    squares_model = np.empty(3)
    squares_base = np.empty(3)
    for k in range(3):
        prior = prior_sum[k] / count * scale
        baseline = base_sum[k] / count
        out[k] = prior
        out[6 + k] = baseline
        squares_model[k] = (prior - velocity[k]) * (prior - velocity[k])
        squares_base[k] = (baseline - velocity[k]) * (baseline - velocity[k])
    error_model = math.sqrt(squares_model[0] + (squares_model[1] + squares_model[2]))
    error_base = math.sqrt(squares_base[0] + (squares_base[1] + squares_base[2]))
    psi_model = gamma_lam * psi[0] + error_model
    psi_base = gamma_lam * psi[1] + error_base
    out[3] = psi_model
    out[4] = psi_base
    out[5] = 1 - psi_model / psi_base if psi_base > 0 else 0.0
    return 0


def _displacement(coefficients, basis, d_basis, nominal, nominal_rate, weights, interaction, step, small,
                  jacobian, pose, pose_jacobian):
    """Net motion per cycle of a candidate gait from an unbatched model's terms (the arithmetic of
    :func:`geogait.models._displacement.displacement_from_terms`: eq. 3 at the Gauss nodes, the
    fourth-order Magnus step, exact exponentials, and with ``jacobian`` their chain rule).

    ``coefficients`` ``(d, c)``, ``basis`` and ``d_basis`` ``(2n, c)``, ``nominal`` and ``nominal_rate``
    ``(2n, d)``, ``weights`` ``(2n, r, 3)``; writes ``pose`` ``(3,)`` and ``pose_jacobian`` ``(3, d c)``.
    """
    d, c = coefficients.shape
    n_nodes = basis.shape[0]
    n_params = d * c
    rate = 2 * math.pi  # the models regress in cycle time
    delta, delta_rate = np.empty(d), np.empty(d)
    velocity = np.empty((n_nodes, 3))
    velocity_jacobian = np.zeros((n_nodes, 3, n_params))
    d_delta, d_rate = np.empty((3, d)), np.empty((3, d))
    for q in range(n_nodes):
        for j in range(d):
            value, slope = 0.0, 0.0
            for k in range(c):
                value += basis[q, k] * coefficients[j, k]
                slope += d_basis[q, k] * coefficients[j, k]
            delta[j] = value - nominal[q, j]
            delta_rate[j] = (slope - nominal_rate[q, j]) * rate
        for o in range(3):
            total = weights[q, 0, o]
            for j in range(d):
                total += delta[j] * weights[q, 1 + j, o] + delta_rate[j] * weights[q, 1 + d + j, o]
            if interaction:
                for i in range(d):
                    for j in range(d):
                        total += delta[i] * delta_rate[j] * weights[q, 1 + 2 * d + i * d + j, o]
            velocity[q, o] = total / rate
        if not jacobian:
            continue
        for o in range(3):  # dξ/dδ_i = B_i + Σ_j ∂A_ij δ̇_j and dξ/dδ̇_j = A_j + Σ_i ∂A_ij δ_i
            for i in range(d):
                d_delta[o, i] = weights[q, 1 + i, o]
                d_rate[o, i] = weights[q, 1 + d + i, o]
            if interaction:
                for i in range(d):
                    for j in range(d):
                        bilinear = weights[q, 1 + 2 * d + i * d + j, o]
                        d_delta[o, i] += bilinear * delta_rate[j]
                        d_rate[o, j] += bilinear * delta[i]
            for j in range(d):
                for k in range(c):
                    velocity_jacobian[q, o, j * c + k] = (d_delta[o, j] * basis[q, k]
                                                          + d_rate[o, j] * rate * d_basis[q, k]) / rate
    _integrate(velocity, velocity_jacobian, step, small, jacobian, pose, pose_jacobian)


def _shape_space_displacement(shape, rate, weights, lower, variable, degree, order, exponents, scale, basis, d_basis,
                              step, small, jacobian, pose, pose_jacobian):
    """Net motion per cycle of a gait under an unbatched :class:`~geogait.models.ShapeSpaceModel` (the
    arithmetic of its ``predict_displacement``): the monomials f(θ/s) degree by degree
    (``f_l = f_{l − e_i} r_i``, ``order`` = the monomials sorted by degree), ξ = Σ W f θ' at the Gauss
    nodes, and with ``jacobian`` ∂ξ/∂c = U b + V b' (U = Σ W ∂f/∂r θ'/s, V = Σ W f); then
    :func:`_integrate`. ``shape`` and ``rate`` ``(2n, d)``, ``weights`` ``(m, d, 3)``."""
    n_nodes, d = shape.shape
    m, c = weights.shape[0], basis.shape[1]
    n_params = d * c
    values, slopes, along = np.empty(m), np.empty((m, d)), np.empty((m, 3))
    u, v, scaled = np.empty((3, d)), np.empty((3, d)), np.empty(d)
    velocity = np.empty((n_nodes, 3))
    velocity_jacobian = np.zeros((n_nodes, 3, n_params))
    for q in range(n_nodes):
        for i in range(d):
            scaled[i] = shape[q, i] / scale
        for index in range(m):
            l = order[index]
            values[l] = 1.0 if degree[l] == 0 else values[lower[l, variable[l]]] * scaled[variable[l]]
        for l in range(m):
            for k in range(3):
                total = 0.0
                for j in range(d):
                    total += rate[q, j] * weights[l, j, k]
                along[l, k] = total
        for k in range(3):
            total = 0.0
            for l in range(m):
                total += values[l] * along[l, k]
            velocity[q, k] = total
        if not jacobian:
            continue
        for l in range(m):
            for i in range(d):
                slopes[l, i] = exponents[l, i] * values[lower[l, i]]
        for k in range(3):
            for i in range(d):
                first, second = 0.0, 0.0
                for l in range(m):
                    first += slopes[l, i] * along[l, k]
                    second += values[l] * weights[l, i, k]
                u[k, i], v[k, i] = first / scale, second
        for k in range(3):
            for i in range(d):
                for cc in range(c):
                    velocity_jacobian[q, k, i * c + cc] = u[k, i] * basis[q, cc] + v[k, i] * d_basis[q, cc]
    _integrate(velocity, velocity_jacobian, step, small, jacobian, pose, pose_jacobian)

def _integrate(velocity, velocity_jacobian, step, small, jacobian, pose, pose_jacobian):
    """The net motion of one cycle from body velocities per unit phase at the Gauss nodes ``(2n, 3)`` (and
    their derivatives ``(2n, 3, p)``): :func:`geogait.se2.integrate_cycle`'s arithmetic (fourth-order
    Magnus steps, exact exponentials, their chain rule); writes ``pose`` ``(3,)`` and ``pose_jacobian``."""
    n_nodes, n_params = velocity.shape[0], velocity_jacobian.shape[2]
    # Magnus: Ω = h/2 (ξ₁ + ξ₂) + √3/12 h² [ξ₁, ξ₂], then the product of exponentials
    half, curvature = step / 2, math.sqrt(3) / 12 * step**2
    heading = 0.0
    pose[0], pose[1] = 0.0, 0.0
    d_heading = np.zeros(n_params)
    if jacobian:
        pose_jacobian[:, :] = 0.0
    for m in range(n_nodes // 2):
        a, b = 2 * m, 2 * m + 1
        vx = half * (velocity[a, 0] + velocity[b, 0]) + curvature * (velocity[a, 1] * velocity[b, 2]
                                                                      - velocity[a, 2] * velocity[b, 1])
        vy = half * (velocity[a, 1] + velocity[b, 1]) + curvature * (velocity[a, 2] * velocity[b, 0]
                                                                      - velocity[a, 0] * velocity[b, 2])
        omega = half * (velocity[a, 2] + velocity[b, 2])
        w2 = omega * omega
        if abs(omega) < small:
            s_coef, c_coef = 1 - w2 / 6 + w2 * w2 / 120, omega / 2 - omega * w2 / 24
            ds, dc = -omega / 3 + omega * w2 / 30, 0.5 - w2 / 8
        else:
            s_coef, c_coef = math.sin(omega) / omega, (1 - math.cos(omega)) / omega
            ds = (omega * math.cos(omega) - math.sin(omega)) / omega**2
            dc = (omega * math.sin(omega) - 1 + math.cos(omega)) / omega**2
        ux, uy = s_coef * vx - c_coef * vy, c_coef * vx + s_coef * vy
        cos, sin = math.cos(heading), math.sin(heading)
        rx, ry = cos * ux - sin * uy, sin * ux + cos * uy
        pose[0] += rx
        pose[1] += ry
        if jacobian:
            for p in range(n_params):
                fa = (velocity_jacobian[a, 0, p], velocity_jacobian[a, 1, p], velocity_jacobian[a, 2, p])
                fb = (velocity_jacobian[b, 0, p], velocity_jacobian[b, 1, p], velocity_jacobian[b, 2, p])
                dvx = half * (fa[0] + fb[0]) + curvature * (
                    (fa[1] * velocity[b, 2] - fa[2] * velocity[b, 1])
                    + (velocity[a, 1] * fb[2] - velocity[a, 2] * fb[1]))
                dvy = half * (fa[1] + fb[1]) + curvature * (
                    (fa[2] * velocity[b, 0] - fa[0] * velocity[b, 2])
                    + (velocity[a, 2] * fb[0] - velocity[a, 0] * fb[2]))
                domega = half * (fa[2] + fb[2])
                dux = (ds * vx - dc * vy) * domega + s_coef * dvx - c_coef * dvy
                duy = (dc * vx + ds * vy) * domega + c_coef * dvx + s_coef * dvy
                pose_jacobian[0, p] += cos * dux - sin * duy - ry * d_heading[p]
                pose_jacobian[1, p] += sin * dux + cos * duy + rx * d_heading[p]
                pose_jacobian[2, p] += domega
                d_heading[p] += domega  # Σ of the steps before the next one
        heading += omega
    pose[2] = heading


def _nearest_segment(x, y, start_x, start_y, step_x, step_y, length, best, along):
    """For each position ``(x[i], y[i])``, the first of the shared candidate segments nearest it
    (``best[i]``) and the fraction along it (``along[i]``): the arithmetic of
    :meth:`geogait.control.ReferencePath.project`, element by element (so the same bits), without its
    ``(positions, candidates)`` temporaries."""
    for i in range(x.shape[0]):
        nearest, chosen, fraction_chosen = np.inf, 0, 0.0
        for k in range(start_x.shape[0]):
            ex, ey = x[i] - start_x[k], y[i] - start_y[k]
            fraction = min(max((ex * step_x[k] + ey * step_y[k]) / length[k] ** 2, 0.0), 1.0)
            ex -= fraction * step_x[k]
            ey -= fraction * step_y[k]
            distance = ex * ex + ey * ey
            if distance < nearest:
                nearest, chosen, fraction_chosen = distance, k, fraction
        best[i], along[i] = chosen, fraction_chosen


def _compile(function):
    """``function`` compiled by numba (cached on disk where it can be), or None when numba is missing. The
    net-motion kernels call :func:`_integrate`, compiled (once) before them."""
    global _missing, _integrate
    try:
        import numba
    except ImportError as error:
        _missing = str(error)
        return None

    def jit(python_function):
        try:
            return numba.njit(cache=True, nogil=True, error_model="numpy")(python_function)
        except RuntimeError:  # no writable cache directory (read-only install, no NUMBA_CACHE_DIR): compile per process
            return numba.njit(nogil=True, error_model="numpy")(python_function)

    if function is not _learn_one and not hasattr(_integrate, "py_func"):
        _integrate = jit(_integrate)
    return jit(function)


def learn_one_kernel():
    """The compiled kernel, or None when numba is missing or the fast path is switched off (:data:`ENABLED`)."""
    global _kernel
    if not ENABLED:
        return None
    if _kernel is None and _missing is None:
        _kernel = _compile(_learn_one)
    return _kernel


def nearest_segment_kernel():
    """The compiled nearest-segment search (:func:`_nearest_segment`), or None as for :func:`learn_one_kernel`."""
    one = np.ones(1)
    return _loaded(_nearest_segment, lambda: (one, one, one, one, one, one, one, np.zeros(1, dtype=np.int64),
                                              np.empty(1)))


def displacement_kernel():
    """The compiled net-motion kernel (:func:`_displacement`), or None as for :func:`learn_one_kernel`."""
    return _loaded(_displacement, lambda: (np.zeros((1, 3)), np.ones((2, 3)), np.ones((2, 3)), np.zeros((2, 1)),
                                           np.zeros((2, 1)), np.zeros((2, 4, 3)), True, 1.0, 1e-4, True,
                                           np.empty(3), np.empty((3, 3))))


def shape_space_kernel():
    """The compiled net motion of a shape-space model (:func:`_shape_space_displacement`), or None as for
    :func:`learn_one_kernel`."""
    index = np.zeros((1, 1), dtype=np.int64)
    return _loaded(_shape_space_displacement, lambda: (
        np.zeros((2, 1)), np.ones((2, 1)), np.zeros((1, 1, 3)), index, np.zeros(1, dtype=np.int64),
        np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.int64), index, 1.0, np.ones((2, 3)), np.ones((2, 3)), 1.0,
        1e-4, True, np.empty(3), np.empty((3, 3))))


def _loaded(function, trial_arguments):
    """``function`` compiled and loaded (one trial call on ``trial_arguments()``), built once per process;
    None when switched off, when numba is missing, or when the compile or its cache is broken (then the
    NumPy reference path serves, and the load is not tried again)."""
    if not ENABLED:
        return None
    name = function.__name__
    if name not in _kernels_loaded:
        kernel = _compile(function) if _missing is None else None
        if kernel is not None:
            try:
                kernel(*trial_arguments())
            except Exception:  # noqa: BLE001  a broken compile or cache must not stop the reference path
                kernel = None
        _kernels_loaded[name] = kernel
    return _kernels_loaded[name]


def warm_up() -> bool:
    """Load (or compile, the first time after an install) the kernel now, not at the first sample; returns
    :func:`fast_path_available`. A real-time loop calls it before its first sample (``geogait stream``)."""
    global _kernel, _missing
    kernel = learn_one_kernel()
    if kernel is None:
        return False
    one = np.ones(1)
    try:
        _call_once(kernel, one)
    except Exception as error:  # noqa: BLE001  a broken compile or cache must not stop the reference path
        _kernel, _missing = None, f"the compiled kernel failed to load ({type(error).__name__}: {error})"
        return False
    return True


def _call_once(kernel, one):
    kernel(0.0, one * 0.5, one, np.zeros(3), 1.0, 1e9, 1e12, True, np.zeros(1), 4.0, np.zeros((1, 1)),
           np.zeros((1, 1)), True, np.zeros((1, 4, 3)), np.eye(4)[None], np.zeros(1, dtype=np.int64), 0.99, 4.0,
           np.zeros((1, 1, 3)), np.ones((1, 1, 1)), np.zeros(1, dtype=np.int64), 0.99, 1.0, np.zeros(2), 0.995,
           np.empty(9))


def fast_path_available() -> bool:
    """Whether one-sample updates run compiled (numba installed and :data:`ENABLED`)."""
    return learn_one_kernel() is not None


def fast_path_note() -> str | None:
    """One line saying the one-sample path runs in pure NumPy and what to install; None when it is compiled."""
    if fast_path_available():
        return None
    if not ENABLED:
        return "note: the compiled one-sample path is switched off; samples are learned by the NumPy reference path"
    return ("note: numba is not installed, so samples are learned one at a time by the NumPy reference path "
            "(about 10x slower); pip install 'geogait[fast]' for the compiled path")
