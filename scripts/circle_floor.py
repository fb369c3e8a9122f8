#!/usr/bin/python3
"""Lower bounds on the circle target's field error (docs/planning.md, "The circle target and its
floor"): the best shape error any field of a class can reach on the specs' 11x11 grid over
[-0.1, 0.1]^2, R = 5 cm, for three ring attractors (q = rho^2/R^2, t and r the unit tangential and
radial vectors, z = x + i y):

  circle (the definition of `vinci field-design`):  v = (z x r + (1 - q)/(1 + q) r) / R
  normal form (Hopf / Stuart-Landau):               v = (z x r + (1 - q) r) / R
  old (the definition until Nov 2026):              v = t + (R - rho)/R r   (unit speed, jumps at 0)

usage: scripts/circle_floor.py [--radius R]

For each target prints:
  1. polynomial fields in (x, y) of degree 1 (affine: a field without a ring) and 3;
  2. smooth rotationally symmetric fields v = z h(|z|^2), h a complex polynomial of degree 0..5
     (a smooth field symmetric about the centre has this form);
  3. the idealised wobble mechanism: c1 e^{i theta} G(alpha rho / g) + c2 z, c1, c2 complex, where
     G(a) is the velocity of the cycle-averaged theory for a circular translation of unit speed
     under the normal force g (1 + a cos(omega t - theta)) of a plate whose tilt axis turns at the
     base frequency (angular acceleration alpha), N clipped at 0 when a > 1 (the part flies);
     the superposition with a linear field (a whirlpool, a sink) is assumed, which the force
     balance does not grant: a bound, not a motion;
  4. (circle only) the same with the linear field made by a second wobble: c1 e^{i theta} G(alpha1
     rho / g) + c2 e^{i theta} G(alpha2 rho / g) with alpha1 + alpha2 = 45 rad/s^2, the whole
     vertical budget of the spec's limit formula (9 m/s^2 = 0.1 m (|A_roll| + |A_pitch|) omega^2 for
     a wobble: 0.2 alpha), nothing left for a vertical vibration;
  5. how much of the ring the metric sees: the error of the target itself with its outward radial
     part removed (no outward draw inside the ring: parts spiral into the centre), and with no
     radial part at all (a pure circulation: no drawing onto the ring), and the share of the
     target's squared speed at the grid points within 1.5 R.
A fit's "cancellation" is the RMS speed of its largest term over that of the fitted field.
"""
import argparse

import numpy as np

G_ACC = 9.81
GRID = np.linspace(-0.1, 0.1, 11)
X, Y = (a.ravel() for a in np.meshgrid(GRID, GRID))
Z = X + 1j * Y
RHO = np.abs(Z)
E = np.where(RHO > 0, Z / np.where(RHO > 0, RHO, 1.0), 0.0)  # e^{i theta}, 0 at the centre


def fit(columns, target):
    """Best shape error of a complex-linear combination of the complex fields `columns`."""
    a = np.stack(columns, 1)
    real = np.concatenate([np.concatenate([a.real, a.imag]),
                           np.concatenate([-a.imag, a.real])], 1)
    t = np.concatenate([target.real, target.imag])
    c, *_ = np.linalg.lstsq(real, t, rcond=None)
    v = real @ c
    return np.sqrt(max(0.0, 2 - 2 * v @ t / np.linalg.norm(v) / np.linalg.norm(t)))


def cancellation(columns, target):
    """The largest RMS speed of one term c_k column_k of the best complex-linear combination over
    the RMS speed of the combination: 1 when nothing cancels; a large value means the field is the
    small difference of large ones, which no real plate delivers to that precision."""
    a = np.stack(columns, 1)
    c, *_ = np.linalg.lstsq(a, target, rcond=None)
    net = np.sqrt(np.mean(np.abs(a @ c)**2))
    return max(np.sqrt(np.mean(np.abs(a[:, k] * c[k])**2)) for k in range(len(columns))) / net


def fit_real(columns, target):
    """Best shape error of a real-linear combination of the complex fields `columns`."""
    a = np.stack(columns, 1)
    real = np.concatenate([a.real, a.imag])
    t = np.concatenate([target.real, target.imag])
    c, *_ = np.linalg.lstsq(real, t, rcond=None)
    v = real @ c
    return np.sqrt(max(0.0, 2 - 2 * v @ t / np.linalg.norm(v) / np.linalg.norm(t)))


_WOBBLE = {}


def wobble_response(a, samples=2048, iterations=2000):
    """G(a): the weighted geometric median of the unit circle e^{it} with weights max(0, 1 + a cos t)
    (Weiszfeld iterations); real by symmetry."""
    key = round(a, 12)
    if key in _WOBBLE:
        return _WOBBLE[key]
    t = (np.arange(samples) + 0.5) / samples * 2 * np.pi
    u = np.exp(1j * t)
    w = np.maximum(0.0, 1 + a * np.cos(t))
    v = 0j
    for _ in range(iterations):
        ww = w / (np.abs(v - u) + 1e-15)
        v = (ww * u).sum() / ww.sum()
    _WOBBLE[key] = v.real
    return v.real


def wobble_field(alpha):
    """e^{i theta} G(alpha rho / g) on the grid."""
    return E * np.array([wobble_response(alpha * rho / G_ACC) for rho in RHO])


def shape_error(v, t):
    """The field error of docs/planning.md between the complex fields v and t."""
    a = v / np.sqrt(np.mean(np.abs(v)**2))
    b = t / np.sqrt(np.mean(np.abs(t)**2))
    return np.sqrt(np.mean(np.abs(a - b)**2))


def targets(r):
    q = RHO**2 / r**2
    return [("circle", "(z x r + (1 - q)/(1 + q) r) / R", Z / r * (1j + (1 - q) / (1 + q))),
            ("normal form", "(z x r + (1 - q) r) / R", Z / r * (1j + 1 - q)),
            ("old", "t + (R - rho)/R r", E * (1j + (r - RHO) / r))]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--radius", type=float, default=0.05)
    r = ap.parse_args().radius
    corner = RHO.max()
    for name, formula, target in targets(r):
        print("%s v = %s, R = %g m, on the 11x11 grid: best shape error of" % (name, formula, r))
        for degree in (1, 3):
            cols = [X**i * Y**j * unit for i in range(degree + 1) for j in range(degree + 1 - i)
                    for unit in (1.0 + 0j, 1j)]
            print("  a polynomial field of degree %d: %.3f" % (degree, fit_real(cols, target)))
        print("  a smooth symmetric field z h(|z|^2), deg h = 0..5: %s" % " / ".join(
            "%.3f" % fit([Z * RHO**(2 * k) for k in range(d + 1)], target) for d in range(6)))
        print("  the idealised wobble mechanism c1 e^{i theta} G(alpha rho/g) + c2 z:")
        for alpha in (45, 64, 100, 200):
            cols = [wobble_field(alpha), Z]
            print("    alpha %3d rad/s^2 (normal acceleration amplitude %4.1f m/s^2 at the corner, "
                  "a = 1 at rho = %.3f m): %.3f (cancellation %.1f)" %
                  (alpha, alpha * corner, G_ACC / alpha, fit(cols, target),
                   cancellation(cols, target)))
        if name == "circle":
            print("  two wobbles c1 e^{i theta} G(alpha1 rho/g) + c2 e^{i theta} G(alpha2 rho/g), "
                  "alpha1 + alpha2 = 45 rad/s^2:")
            for a1 in (44, 40, 35, 30, 25):
                cols = [wobble_field(a1), wobble_field(45 - a1)]
                print("    alpha1 %2d, alpha2 %2d: %.3f (cancellation %.1f)" %
                      (a1, 45 - a1, fit(cols, target), cancellation(cols, target)))
        radial = (target * np.conj(E)).real
        tangential = (target * np.conj(E)).imag
        near = RHO <= 1.5 * r
        print("  the target without its outward radial part (no ring: inside, parts spiral into "
              "the centre): %.3f" % shape_error(E * (np.minimum(radial, 0) + 1j * tangential),
                                                target))
        print("  the target without its radial part (a pure circulation): %.3f" %
              shape_error(E * 1j * tangential, target))
        print("  share of the target's squared speed within 1.5 R (%d of %d points): %.2f" %
              (near.sum(), RHO.size, np.sum(np.abs(target[near])**2) / np.sum(np.abs(target)**2)))


if __name__ == "__main__":
    main()
