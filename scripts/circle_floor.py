#!/usr/bin/python3
"""Lower bounds on the circle target's field error (docs/planning.md, "Why the circle stays far
from 0.1"): the best shape error any field of a class can reach on the specs' 11x11 grid over
[-0.1, 0.1]^2, for the circle target v = t + (R - rho)/R r (R = 5 cm, t and r the unit tangential
and radial vectors; zero at the centre).

usage: scripts/circle_floor.py [--radius R]

Prints, each with its best coefficients fitted by least squares (the shape error of the best
scale is sqrt(2 - 2 cos angle) between the fields as vectors over the grid):
  1. polynomial fields in (x, y) of degree 1 and 3 (all coefficients free);
  2. smooth rotationally symmetric fields v = z h(|z|^2), z = x + i y, h a complex polynomial of
     degree 0..5 (a smooth field symmetric about the centre has this form);
  3. the idealised wobble mechanism: c1 e^{i theta} G(alpha rho / g) + c2 z, c1, c2 complex, where
     G(a) is the velocity of the cycle-averaged theory for a circular translation of unit speed
     under the normal force g (1 + a cos(omega t - theta)) of a plate whose tilt axis turns at the
     base frequency (angular acceleration alpha), N clipped at 0 when a > 1 (the part flies);
     the superposition with a linear field (a whirlpool, a sink) is assumed, which the force
     balance does not grant: a bound, not a motion.
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


def fit_real(columns, target):
    """Best shape error of a real-linear combination of the complex fields `columns`."""
    a = np.stack(columns, 1)
    real = np.concatenate([a.real, a.imag])
    t = np.concatenate([target.real, target.imag])
    c, *_ = np.linalg.lstsq(real, t, rcond=None)
    v = real @ c
    return np.sqrt(max(0.0, 2 - 2 * v @ t / np.linalg.norm(v) / np.linalg.norm(t)))


def wobble_response(a, samples=2048, iterations=2000):
    """G(a): the weighted geometric median of the unit circle e^{it} with weights max(0, 1 + a cos t)
    (Weiszfeld iterations); real by symmetry."""
    t = (np.arange(samples) + 0.5) / samples * 2 * np.pi
    u = np.exp(1j * t)
    w = np.maximum(0.0, 1 + a * np.cos(t))
    v = 0j
    for _ in range(iterations):
        ww = w / (np.abs(v - u) + 1e-15)
        v = (ww * u).sum() / ww.sum()
    return v.real


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--radius", type=float, default=0.05)
    r = ap.parse_args().radius
    target = E * (1j + (r - RHO) / r)
    print("circle R = %g m on the 11x11 grid: best shape error of" % r)
    for degree in (1, 3):
        cols = [X**i * Y**j * unit for i in range(degree + 1) for j in range(degree + 1 - i)
                for unit in (1.0 + 0j, 1j)]
        print("  a polynomial field of degree %d: %.3f" % (degree, fit_real(cols, target)))
    for degree in range(6):
        cols = [Z * RHO**(2 * k) for k in range(degree + 1)]
        print("  a smooth symmetric field z h(|z|^2), deg h = %d: %.3f" % (degree, fit(cols, target)))
    print("  the idealised wobble mechanism c1 e^{i theta} G(alpha rho/g) + c2 z:")
    corner = RHO.max()
    for alpha in (45, 64, 100, 150, 200, 300, 500):
        g = np.array([wobble_response(alpha * rho / G_ACC) for rho in RHO])
        print("    alpha %3d rad/s^2 (normal acceleration amplitude %4.1f m/s^2 at the corner, "
              "a = 1 at rho = %.3f m): %.3f" %
              (alpha, alpha * corner, G_ACC / alpha, fit([E * g, Z], target)))


if __name__ == "__main__":
    main()
