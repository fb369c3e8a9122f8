#!/usr/bin/python3
"""Global search of plate motions on the point theory (docs/planning.md, "The circle target and its
floor"): how well can any motion of the field-design family match a target, if the simulated
field were the cycle-averaged theory of docs/field.md? At the actuator's amplitudes this theory
does not predict the simulation (docs/planning.md, "Theory versus simulation"): use
scripts/plate_point_model.py and scripts/circle_model_search.py instead.

usage: scripts/field_theory_search.py TARGET [--radius R] [--harmonics 1|2|3] [--generations N]
                                     [--limits] [--local SCENE.yaml [--write-scene OUT.yaml]]
       TARGET: circle | circle_old | whirlpool | saddle | sink

--limits: amplitude bounds from the acceleration limits of the issue's actuator instead of the
bundled specs' bounds: harmonic k of x, y within 15 m/s^2, of roll, pitch, yaw within 100 rad/s^2,
of z within 9 m/s^2 (A <= 0.999 limit / (2 pi k f)^2: the printed 4 digits stay within), and
each DOF's sum over its harmonics (2 pi k f)^2 |A| (vinci field-design's bound) within 0.999 of its
limit (a penalty 10 relative excess).

--local SCENE.yaml: instead of the global search, a local one (scipy's Powell, 4000 evaluations)
from the plate motion of a scene (e.g. a field-design best.yaml; harmonics the scene lacks start
at zero), with the actuator limit as a penalty 10 (peak - 8.991)/9 (8.991: the printed 4 digits stay
below 9 m/s^2); prints the motion found (used to
seed a simulation search with --start: docs/planning.md, the circle). --write-scene writes
SCENE.yaml with that motion (as printed: 4 digits, phases wrapped to [-pi, pi]) for the plate,
a scene `vinci field-design --start` takes.

The theory (an independent numpy implementation of the force balance of docs/field.md, not
plate_theory.h): a point part at plate point p = (x, y) slides with the constant velocity v that
minimizes sum_t N(t, p) |v - v_p(t, p)| (a weighted geometric median, Weiszfeld iterations), with
v_p = (xdot - yawdot y, ydot + yawdot x) and N = max(0, g + zddot + rollddot y - pitchddot x), small
angles, 64 samples per cycle. Every DOF x, y, z, roll, pitch, yaw is A sin(2 pi k f t + phi),
k = 1 (and 2 with --harmonics 2), f = 30 Hz, with the amplitude bounds of the bundled specs and the
9 m/s^2 actuator limit; x's first phase is the time reference. The grid is the specs' 11x11 over
[-0.1, 0.1]^2 and the error the shape field error of docs/planning.md. scipy's differential
evolution (seed 1) searches; prints the best error and motion.
"""
import argparse
import sys

import numpy as np
from scipy.optimize import differential_evolution

G = np.linspace(-0.1, 0.1, 11)
X, Y = np.meshgrid(G, G)
X, Y = X.ravel(), Y.ravel()
F = 30.0
W = 2 * np.pi * F
T = (np.arange(64) + 0.5) / 64 / F
DOFS = ["x", "y", "z", "roll", "pitch", "yaw"]
BOUND = {"x": 1.2e-3, "y": 1.2e-3, "z": 2.5e-4, "roll": 1.2e-3, "pitch": 1.2e-3, "yaw": 0.04}


def target(kind, radius):
    rho = np.hypot(X, Y)
    safe = np.where(rho > 0, rho, 1.0)
    rx, ry = X / safe, Y / safe
    if kind == "circle":  # v = (z x r + (1 - q)/(1 + q) r) / R, q = rho^2/R^2 (docs/planning.md)
        ratio = (1 - (rho / radius)**2) / (1 + (rho / radius)**2)
        vx, vy = (-Y + ratio * X) / radius, (X + ratio * Y) / radius
    elif kind == "circle_old":  # the definition until Nov 2026: t + (R - rho)/R r, unit speed
        vx, vy = -ry + (radius - rho) / radius * rx, rx + (radius - rho) / radius * ry
        vx, vy = np.where(rho > 0, vx, 0.0), np.where(rho > 0, vy, 0.0)
    elif kind == "whirlpool":
        vx, vy = -Y, X
    elif kind == "saddle":
        vx, vy = X, -Y
    elif kind == "sink":
        vx, vy = -X, -Y
    else:
        raise SystemExit("unknown target " + kind)
    return np.stack([vx, vy], 1)


def field(motion):
    """motion: list of (dof, order, amplitude, phase)."""
    rate = {d: np.zeros_like(T) for d in DOFS}
    acc = {d: np.zeros_like(T) for d in DOFS}
    for dof, k, a, phi in motion:
        w = k * W
        rate[dof] = rate[dof] + a * w * np.cos(w * T + phi)
        acc[dof] = acc[dof] - a * w * w * np.sin(w * T + phi)
    vpx = rate["x"][None, :] - rate["yaw"][None, :] * Y[:, None]
    vpy = rate["y"][None, :] + rate["yaw"][None, :] * X[:, None]
    n = np.maximum(0.0, 9.81 + acc["z"][None, :] + acc["roll"][None, :] * Y[:, None] -
                   acc["pitch"][None, :] * X[:, None])
    v = np.stack([(n * vpx).sum(1), (n * vpy).sum(1)], 1) / np.maximum(n.sum(1), 1e-12)[:, None]
    for _ in range(60):
        d = np.sqrt((v[:, :1] - vpx)**2 + (v[:, 1:] - vpy)**2 + 1e-14)
        w = n / d
        v = np.stack([(w * vpx).sum(1), (w * vpy).sum(1)], 1) / np.maximum(w.sum(1), 1e-30)[:, None]
    return v


def shape_error(v, t):
    sv = np.sqrt((v**2).sum(1).mean())
    st = np.sqrt((t**2).sum(1).mean())
    return 1.0 if sv == 0 else np.sqrt(((v / sv - t / st)**2).sum(1).mean())


def scene_motion(path):
    """(dof, order) -> (amplitude, phase) of the first prescribed body of a scene file."""
    import yaml
    scene = yaml.safe_load(open(path))
    plate = next(b for b in scene["bodies"] if b.get("kind") == "prescribed")
    out = {}
    for dof in DOFS:
        for i, h in enumerate(plate["motion"].get(dof, {}).get("harmonics", [])):
            out[(dof, int(h.get("order", i + 1)))] = (float(h["amplitude"]), float(h["phase"]))
    return out


def local_search(a, tg, slots):
    from scipy.optimize import minimize
    start = scene_motion(a.local)
    limit = {"x": 15.0, "y": 15.0, "z": 9.0, "roll": 100.0, "pitch": 100.0, "yaw": 100.0}

    def bound(d, k):
        return 0.999 * limit[d] / (W * k)**2 if a.limits else BOUND[d] / k

    u0 = []
    for d, k in slots:
        amp, phi = start.get((d, k), (0.0, 0.0))
        u0 += [float(np.clip(amp / bound(d, k), -1, 1)), phi]

    def motion(u):
        return [(d, k, float(np.clip(u[2 * i], -1, 1)) * bound(d, k), u[2 * i + 1])
                for i, (d, k) in enumerate(slots)]

    def peak(m):
        return sum(W**2 * k**2 * abs(amp) * (1.0 if d == "z" else 0.1)
                   for d, k, amp, _ in m if d in ("z", "roll", "pitch"))

    def objective(u):
        m = motion(u)
        p = peak(m)
        penalty = 10 * (p - 8.991) / 9 if p > 8.991 else 0.0
        if a.limits:
            for d in DOFS:
                dof_peak = sum((W * k)**2 * abs(amp) for dd, k, amp, _ in m if dd == d)
                penalty += 10 * max(0.0, dof_peak / (0.999 * limit[d]) - 1.0)
        return shape_error(field(m), tg) + penalty

    print("start: theory shape error %.3f" % objective(np.array(u0)))
    r = minimize(objective, np.array(u0), method="Powell",
                 options={"maxfev": 4000, "xtol": 1e-4, "ftol": 1e-6})
    print("%s R=%g harmonics=%d local: theory shape error %.3f, peak normal acceleration %.2f "
          "m/s^2 (%d evaluations)" % (a.target, a.radius, a.harmonics, r.fun, peak(motion(r.x)),
                                      r.nfev))
    printed = []
    for d, k, amp, phi in motion(r.x):
        line = "  %-5s order %d: amplitude %+.3e, phase %+.3f" % (d, k, amp, phi)
        print(line)
        amp, phi = float(line.split()[4].rstrip(",")), float(line.split()[6])
        printed.append((d, k, amp, (phi + np.pi) % (2 * np.pi) - np.pi))
    if a.write_scene:
        write_scene(a.local, a.write_scene, printed, " ".join(sys.argv[1:]), r.fun)


def write_scene(base, out, motion, command, error):
    """The scene `base` with its first prescribed body's motion replaced by `motion`."""
    import yaml
    scene = yaml.safe_load(open(base))
    plate = next(b for b in scene["bodies"] if b.get("kind") == "prescribed")
    m = {"frequency": F}
    for d in DOFS:
        hs = [{"order": k, "amplitude": amp, "phase": phi} for dd, k, amp, phi in motion if dd == d]
        if hs:
            m[d] = {"harmonics": hs}
    plate["motion"] = m
    with open(out, "w") as f:
        f.write("# Written by scripts/field_theory_search.py %s\n# (theory shape error %.3f)\n" %
                (command, error))
        yaml.safe_dump(scene, f, sort_keys=False, default_flow_style=None, width=100)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("target")
    ap.add_argument("--radius", type=float, default=0.05)
    ap.add_argument("--harmonics", type=int, default=1, choices=[1, 2, 3])
    ap.add_argument("--generations", type=int, default=40)
    ap.add_argument("--local", metavar="SCENE.yaml")
    ap.add_argument("--limits", action="store_true")
    ap.add_argument("--write-scene", metavar="OUT.yaml")
    a = ap.parse_args()
    tg = target(a.target, a.radius)
    slots = [(d, k) for k in range(1, a.harmonics + 1) for d in DOFS]
    if a.local:
        local_search(a, tg, slots)
        return

    def motion(u):
        return [(d, k, u[2 * i] * BOUND[d] / k, u[2 * i + 1] * np.pi)
                for i, (d, k) in enumerate(slots)]

    def peak(m):
        return sum(W**2 * k**2 * abs(amp) * (1.0 if d == "z" else 0.1)
                   for d, k, amp, _ in m if d in ("z", "roll", "pitch"))

    def objective(u):
        m = motion(u)
        p = peak(m)
        return 10 + p / 9.0 if p > 9.0 else shape_error(field(m), tg)

    bounds = [(-1, 1)] * (2 * len(slots))
    bounds[1] = (-1e-12, 1e-12)  # x's first phase: the time reference (0)
    r = differential_evolution(objective, bounds, seed=1, maxiter=a.generations, popsize=12,
                               tol=1e-6, polish=True)
    print("%s R=%g harmonics=%d: theory shape error %.3f, peak normal acceleration %.2f m/s^2" %
          (a.target, a.radius, a.harmonics, r.fun, peak(motion(r.x))))
    for d, k, amp, phi in motion(r.x):
        print("  %-5s order %d: amplitude %+.3e, phase %+.3f" % (d, k, amp, phi))


if __name__ == "__main__":
    main()
