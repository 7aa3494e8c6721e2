"""The one Newton-Raphson of kinem (Eqs. 4.41, 4.42; docs/solver.md,
"Residual scaling and convergence"), with the final correction and the
factorisation at the corrected configuration that the conditioning monitor
and the rate solves use.

``settle`` is written once, on three operations it finds as globals:
``evaluate``, ``factor`` and ``correct``. The compiled march writes its
statements into its loop, with those of kinem/loop.py's operations (block
and band LUs) in place of their calls (kinem.march, kinem.inline); the
step-by-step analysis runs it as Python with them bound to any linear
solver: LAPACK, SuperLU, least squares, minimum norm (kinem.analysis,
kinem.jit.bound). Here they are unbound.
"""
import numpy as np

from kinem.jit import kernel

# Newton steps are limited to this length in dimensionless coordinates
# (lengths over L, angles in radians): a rough estimate never sends the
# assembly many turns away, and tracking steps are far shorter anyway.
MAX_STEP = 0.5
# A final correction (dimensionless) above this calls for one more: at the
# default tolerance it is about 1e-12; at a loose one (1e-6) about the
# tolerance, and the first correction, made with the last iteration's LU,
# leaves that times the iteration's step (1e-10 of L on the slider-crank).
POLISH = 1e-10
# ``settle``'s status when the residual did not reach the tolerance (or is
# not a number) within the iterations allowed; 0: converged.
NOT_CONVERGED = 4

evaluate = factor = correct = None  # bound by each caller


# A kernel so that its source counts in the march's module names and cache
# check (kinem.jit.sources); numba never compiles it on its own.
@kernel
def settle(q, k, work, tolerance, max_iterations, max_step, finish):
    """Newton-Raphson from q (updated in place) to Phi(q, t_k) = 0, every
    scaled residual |Phi_i| / scale_i at or below the tolerance, steps
    limited to max_step (dimensionless). With ``finish``, then the final
    correction (the position error falls from about the tolerance to about
    its square) with the last iteration's factorisation (a fresh one when q
    already converged), one more when that correction is above POLISH, and
    the factorisation at the corrected q, left in ``work`` for the pivot
    ratio, det sign and rate solves.

    The operations on ``work``: ``evaluate(q, k, work, it)`` Phi at q and
    its max scaled residual (it: the Newton iteration, -1 after
    convergence); ``factor(q, work, final)`` the factorisation at q (final:
    the one left at the end; a step-by-step run with Jacobian reuse may
    hand back a nearby one otherwise); ``correct(q, work, limit)`` q -=
    Phi_q^-1 Phi, the step limited to ``limit``, returning its size before
    the limit. One site of each: the march writes the families' kernels
    out at every site.
    Returns (iterations, max scaled residual, status: 0 or NOT_CONVERGED,
    the last correction's size: the polishing one's when there was one,
    else the final correction's; 0 without ``finish``). At a regular root
    the polishing correction is about the square of the first; at a
    singular one Newton converges linearly and it is of the first's order
    (kinem.tracking.rejected judges it)."""
    it, r, converged, refined, polished, polish, step = 0, np.inf, False, False, False, False, 0.0
    while True:
        if not converged or polish:
            e = evaluate(q, k, work, -1 if converged else it)
            if not converged:
                r = e
                if r <= tolerance:
                    converged = True
                    if not finish:
                        return it, r, 0, 0.0
                elif not r < np.inf or it == max_iterations:
                    return it, r, NOT_CONVERGED, step
        if polish:
            step = correct(q, work, np.inf)
            polish, polished = False, True
        elif converged and not refined and it > 0:
            step = correct(q, work, np.inf)
            refined = True
        factor(q, work, refined)
        if not converged:
            correct(q, work, max_step)
            it += 1
        elif not refined:
            step = correct(q, work, np.inf)
            refined = True
        elif step > POLISH and not polished:
            polish = True
        else:
            return it, r, 0, step
