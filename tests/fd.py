"""Finite-difference checks of a model's Jacobian, nu and gamma.

Along the straight path q(tau) = q + tau qd, t(tau) = t + tau:
    g'(0)  = Phi_q qd + Phi_t                        = Phi_q qd - nu
    g''(0) = (Phi_q qd)_q qd + 2 Phi_qt qd + Phi_tt  = -gamma
so the checks need nothing but Phi. Fourth-order central differences with
step H: truncation error ~ H^4 |Phi^(5)| ~ 1e-12 x (values and rates of
order 1-10), rounding ~ eps |Phi| / H^k, giving ~1e-12 for first and ~1e-9
for second derivatives. The tolerances below leave two orders of margin;
a wrong formula gives errors of order 1.
"""
import numpy as np

H = 1e-3
TOL_FIRST = 1e-8    # Jacobian, nu: relative to max(1, |value|)
TOL_SECOND = 1e-6   # gamma


def d1(f, h=H):
    return (-f(2 * h) + 8 * f(h) - 8 * f(-h) + f(-2 * h)) / (12 * h)


def d2(f, h=H):
    return (-f(2 * h) + 16 * f(h) - 30 * f(0.0) + 16 * f(-h) - f(-2 * h)) / (12 * h * h)


def jacobian_fd(model, q, t):
    J = np.empty((model.m, model.n))
    for c in range(model.n):
        e = np.zeros(model.n)
        e[c] = 1.0
        J[:, c] = d1(lambda s: model.phi(q + s * e, t))
    return J


def errors(model, q, qd, t):
    """(Jacobian error, nu error, gamma error), each relative to max(1, |value|)."""
    J = model.jacobian(q, t, sparse=False)
    Jfd = jacobian_fd(model, q, t)
    path = lambda s: model.phi(q + s * qd, t + s)
    nu_fd = J @ qd - d1(path)
    gamma_fd = -d2(path)
    nu, gamma = model.nu(t), model.gamma(q, qd, t)
    rel = lambda a, b: float(np.max(np.abs(a - b)) / max(1.0, np.max(np.abs(b)))) if a.size else 0.0
    return rel(J, Jfd), rel(nu, nu_fd), rel(gamma, gamma_fd)


def assert_derivatives(model, q, qd, t):
    ej, en, eg = errors(model, q, qd, t)
    assert ej <= TOL_FIRST, f"Jacobian differs from finite differences by {ej:.2e}"
    assert en <= TOL_FIRST, f"nu differs from finite differences by {en:.2e}"
    assert eg <= TOL_SECOND, f"gamma differs from finite differences by {eg:.2e}"
