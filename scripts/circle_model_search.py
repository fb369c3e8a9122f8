#!/usr/bin/python3
"""Screening search for the circle motion on the transient point model (scripts/
plate_point_model.py; docs/planning.md, "The circle target and its floor"): the first harmonics
of x, y, z, roll, pitch, yaw and z's second (with --harmonics 2 the second harmonics of x, y,
roll, pitch, yaw too) over the whole actuator range, within the issue's actuator limits; writes
the best motion as a plate scene (for `vinci field-design --start`, or to centre a spec's box).

usage: scripts/circle_model_search.py [--scan | --ring] [--harmonics 1|2] [--generations N]
                                      [--popsize P] [--seed S] [--steps S] [--cycles K]
                                      [--average N] [--sides N] [--objective shape|ring]
                                      [--min-speed V] [--powell N]
                                      [--start SCENE.yaml | --wobble U,ALPHA,PSI]
                                      [--write-scene OUT.yaml]

--ring: the symmetric family near the sticking threshold, keeping the motions whose radial
velocity turns from outward to inward (a ring), then Powell on x, y, roll, pitch from the best:
the search that seeded the shipped ring (docs/planning.md, "A ring").
--scan: the rotationally symmetric family only (a circular translation with a wobble of the same
frequency, both senses), on a grid of amplitudes from the sticking threshold up, angular
accelerations and phases: the search that found the shipped circle's mechanism.
--start / --wobble: Powell only, from that motion. Otherwise differential evolution from random
(it stalls far from the optimum on this landscape), then Powell.

The limits are vinci field-design's (docs/planning.md, "The objective"): the peak normal
acceleration over the grid Σ (2πkf)² (|A_z| + 0.1 |A_roll| + 0.1 |A_pitch|) ≤ 9 m/s², per DOF
Σ (2πkf)² |A| ≤ 15 m/s² (x, y) and ≤ 100 rad/s² (roll, pitch, yaw); amplitude bounds as the
earlier circle spec (the whole actuator range). A motion beyond them scores 10 + its relative
excess (never chosen). The target, grid and metric are the spec's; the model runs with S steps
per cycle (default 160, the scenes' time step: near the sticking threshold 40 steps misjudge the
error by up to 0.1).
"""
import argparse
import os

import numpy as np
from scipy.optimize import differential_evolution, minimize

import plate_point_model as pm

W = 2 * np.pi * pm.F
LIMIT = {"x": 15.0, "y": 15.0, "z": 9.0, "roll": 100.0, "pitch": 100.0, "yaw": 100.0}
BOUND = {"x": 4.2e-4, "y": 4.2e-4, "z": 2.5e-4, "roll": 2.5e-3, "pitch": 2.5e-3, "yaw": 2.8e-3}
BOUND2 = {"x": 1.05e-4, "y": 1.05e-4, "z": 6.3e-5, "roll": 6.25e-4, "pitch": 6.25e-4,
          "yaw": 7.0e-4}


def slots(harmonics):
    s = [(d, 1) for d in pm.DOFS] + [("z", 2)]
    if harmonics == 2:
        s += [(d, 2) for d in ("x", "y", "roll", "pitch", "yaw")]
    return s


def decode(u, sl):
    """u: (2 len(sl),) in [-1, 1] (amplitude / bound, phase / pi); x's first phase is 0."""
    m = []
    for i, (d, k) in enumerate(sl):
        amp = u[2 * i] * (BOUND[d] if k == 1 else BOUND2[d])
        phi = 0.0 if (d, k) == ("x", 1) else u[2 * i + 1] * np.pi
        m.append((d, k, amp, phi))
    return m


def excess(m):
    peak_n = sum((W * k)**2 * abs(a) * (1.0 if d == "z" else 0.1) for d, k, a, _ in m
                 if d in ("z", "roll", "pitch"))
    worst = peak_n / 9.0 - 1.0
    for dof in pm.DOFS:
        if dof == "z":
            continue
        p = sum((W * k)**2 * abs(a) for d, k, a, _ in m if d == dof)
        worst = max(worst, p / LIMIT[dof] - 1.0)
    return worst


def ring_direction(target):
    """The unit vector (vx stacked over vy on the grid) of the target's part that no affine field
    has (the target minus its least-squares affine fit), and the target's angle to the affine
    fields (the affine floor is 2 sin(angle / 2))."""
    one, zero = np.ones_like(pm.GX), np.zeros_like(pm.GX)
    basis = np.stack([np.concatenate(c) for c in [(one, zero), (zero, one), (pm.GX, zero),
                                                   (pm.GY, zero), (zero, pm.GX), (zero, pm.GY)]], 1)
    q, _ = np.linalg.qr(basis)
    t = np.concatenate([target[:, 0], target[:, 1]])
    perp = t - q @ (q.T @ t)
    return perp / np.linalg.norm(perp), float(np.arcsin(np.linalg.norm(perp) / np.linalg.norm(t)))


def ring_component(v, target):
    """b = v·u / |v|: the share of the field along the target's ring direction u. A field with
    shape error e to the target has b ≥ sin(angle − 2 arcsin(e/2)) (0.074 for e = 0.1)."""
    u, _ = ring_direction(target)
    vv = np.concatenate([v[:, 0], v[:, 1]])
    n = np.linalg.norm(vv)
    return 0.0 if n == 0 else float(vv @ u / n)


def batch_error(us, sl, a, target):
    """Shape errors of the motions us (P, n): the model vectorized over motions and points
    (with a.objective == "ring": minus the ring component b)."""
    return batch_motion_error([decode(u, sl) for u in us], a, target)


def batch_motion_error(motions, a, target):
    """batch_error for a list of motions [(dof, order, amplitude, phase)]: the transient model
    (plate_point_model.transient_field) with the state as (motion, point) arrays."""
    P = len(motions)
    h = 1.0 / pm.F / a.steps
    t = (np.arange(a.cycles * a.steps) + 1) * h
    # per-motion signals (time, motion, 1), broadcast over the points
    rate = {d: np.zeros((t.size, P, 1)) for d in pm.DOFS}
    acc = {d: np.zeros((t.size, P, 1)) for d in pm.DOFS}
    angle = {d: np.zeros((t.size, P, 1)) for d in ("roll", "pitch")}
    for j, m in enumerate(motions):
        r_, a_, g_ = pm.plate_signals(m, t)
        for d in pm.DOFS:
            rate[d][:, j, 0] = r_[d]
            acc[d][:, j, 0] = a_[d]
        for d in angle:
            angle[d][:, j, 0] = g_[d]
    x = np.tile(pm.GX, (P, 1))
    y = np.tile(pm.GY, (P, 1))
    vx, vy = np.zeros_like(x), np.zeros_like(x)
    sx, sy = np.zeros_like(x), np.zeros_like(x)
    start = (a.cycles - a.average) * a.steps
    for i in range(t.size):
        n = np.maximum(pm.G_ACC + acc["z"][i] + acc["roll"][i] * y - acc["pitch"][i] * x, 0.0)
        vx = vx + h * n * angle["pitch"][i]
        vy = vy - h * n * angle["roll"][i]
        vpx = rate["x"][i] - rate["yaw"][i] * y
        vpy = rate["y"][i] + rate["yaw"][i] * x
        vx, vy = pm.friction_step(vx, vy, vpx, vpy, pm.MU * n * h, a.sides)
        x, y = x + h * vx, y + h * vy
        if i >= start:
            sx, sy = sx + vx, sy + vy
    out = np.empty(P)
    for j in range(P):
        v = np.stack([sx[j], sy[j]], 1)
        if a.objective == "ring":
            out[j] = -ring_component(v, target)
        elif a.objective == "circle":
            out[j] = pm.circle_error(v)
        else:
            out[j] = pm.shape_error(v, target)
        speed = np.sqrt((v**2).sum(1).mean())
        if speed < a.min_speed:  # a field too slow to be of use (the metric is scale-free)
            out[j] += 1.0 - speed / a.min_speed
    return out


def objective_batch(us, sl, a, target):
    us = np.atleast_2d(us)
    ex = np.array([excess(decode(u, sl)) for u in us])
    err = np.full(us.shape[0], 0.0)
    ok = ex <= 0
    if ok.any():
        err[ok] = batch_error(us[ok], sl, a, target)
    err[~ok] = 10 + ex[~ok]
    return err


def start_vector(path, sl):
    m, _ = pm.scene_motion(path)
    got = {(d, k): (amp, phi) for d, k, amp, phi in m}
    u = []
    for d, k in sl:
        amp, phi = got.get((d, k), (0.0, 0.0))
        b = BOUND[d] if k == 1 else BOUND2[d]
        phi = (phi + np.pi) % (2 * np.pi) - np.pi
        u += [float(np.clip(amp / b, -1, 1)), phi / np.pi]
    return np.array(u)


def wobble_vector(text, sl):
    """The start vector of --wobble U,ALPHA,PSI."""
    amp, alpha, psi = (float(v) for v in text.split(","))
    tilt = alpha / W**2
    got = {("x", 1): (amp, 0.0), ("y", 1): (amp, -np.pi / 2), ("roll", 1): (tilt, psi),
           ("pitch", 1): (-tilt, psi + np.pi / 2)}
    u = []
    for d, k in sl:
        a_, phi = got.get((d, k), (0.0, 0.0))
        b = BOUND[d] if k == 1 else BOUND2[d]
        phi = (phi + np.pi) % (2 * np.pi) - np.pi
        u += [float(np.clip(a_ / b, -1, 1)), phi / np.pi]
    return np.array(u)


def symmetric_motion(alpha, sense, amp, psi, order=1):
    """A circular translation of amplitude amp (m) with a wobble (roll and pitch in quadrature)
    of angular acceleration alpha (rad/s^2) at phase psi: rotationally symmetric about the
    centre; sense -1 is its mirror image (y and roll reversed)."""
    tilt = alpha / (W * order)**2
    return [("x", order, amp, 0.0), ("y", order, sense * amp, -np.pi / 2),
            ("roll", order, sense * tilt, psi), ("pitch", order, -tilt, psi + np.pi / 2)]


def scan_symmetric(a, target):
    """--scan: the model's field error over the symmetric family (symmetric_motion), both senses,
    from the sticking threshold (plate acceleration = mu g) up: prints the best, returns its
    motion."""
    rows = []
    for alpha in (20.0, 30.0, 35.0, 40.0, 45.0):
        for sense in (1, -1):
            keys = [(alpha, sense, amp, psi) for amp in (5.2e-5, 5.4e-5, 5.6e-5, 6e-5, 7e-5, 8e-5,
                                                         1e-4, 1.5e-4, 2.5e-4, 4.2e-4)
                    for psi in np.arange(16) * np.pi / 8]
            errors = batch_motion_error([symmetric_motion(*k) for k in keys], a, target)
            rows += list(zip(errors, keys))
    rows.sort()
    for e, (alpha, sense, amp, psi) in rows[:8]:
        print("scan: model error %.4f: alpha %g rad/s^2, sense %+d, amplitude %.2e m (plate "
              "acceleration %.2f m/s^2), psi %.4f" % (e, alpha, sense, amp, amp * W**2, psi))
    return symmetric_motion(*rows[0][1])


def ring_radius(v):
    """Where the grid's mean radial velocity turns from outward to inward (m, linear
    interpolation between rings of grid points), or None if it does not (no ring)."""
    prof = [(r, vr) for r, _, vr, _ in pm.radial_profile(v) if r > 0]
    if not prof or prof[0][1] <= 0 or prof[-1][1] >= 0:
        return None
    for (r0, v0), (r1, v1) in zip(prof, prof[1:]):
        if v0 > 0 >= v1:
            return r0 + (r1 - r0) * v0 / (v0 - v1)
    return None


def scan_ring(a):
    """--ring: the symmetric family near and above the sticking threshold (amplitudes 5.0-9.0e-5
    m, 48 phases, alpha 35 and 44.5 rad/s^2, both senses): the circle error of every motion and
    whether its radial velocity changes sign (a ring); prints the best rings, returns the best."""
    keys = [(alpha, sense, amp, psi) for alpha in (35.0, 44.5) for sense in (1, -1)
            for amp in np.arange(5.0, 9.01, 0.25) * 1e-5 for psi in np.arange(48) * np.pi / 24]
    a2 = argparse.Namespace(**{**vars(a), "objective": "circle", "min_speed": 0.0})
    rows = []
    for i in range(0, len(keys), 96):  # chunks: the signals are (steps, motions, 1) arrays
        chunk = keys[i:i + 96]
        errors = batch_motion_error([symmetric_motion(*k) for k in chunk], a2, None)
        rows += list(zip(errors, chunk))
    rows.sort()
    best = None
    shown = 0
    for e, k in rows:
        m = symmetric_motion(*k)
        v, _ = pm.transient_field(m, steps=a.steps, cycles=a.cycles, average=a.average)
        r = ring_radius(v)
        if r is None:
            continue
        best = best or m
        print("ring: model circle error %.4f (whole-field %.4f), ring at %.1f mm: alpha %g "
              "rad/s^2, sense %+d, amplitude %.3e m, psi %.4f" %
              (e, pm.shape_error(v, pm.circle_target(pm.GX, pm.GY)), 1e3 * r, *k), flush=True)
        shown += 1
        if shown == 8:
            break
    print("best non-ring motion of the family: circle error %.4f (%s)" %
          next((e, k) for e, k in rows
               if ring_radius(pm.transient_field(symmetric_motion(*k), steps=a.steps)[0]) is None))
    return best


def write_scene(base, out, motion, note, frequency=None, tool="circle_model_search.py"):
    """Writes scene `base` with its prescribed body's motion replaced by `motion` (a list of
    (dof, order, amplitude, phase)) at `frequency` (default the model's pm.F) to `out`."""
    import yaml
    scene = yaml.safe_load(open(base))
    plate = next(b for b in scene["bodies"] if b.get("kind") == "prescribed")
    mm = {"frequency": float(pm.F if frequency is None else frequency)}
    for d in pm.DOFS:
        hs = [{"order": k, "amplitude": float(amp), "phase": float(phi)}
              for dd, k, amp, phi in motion if dd == d]
        if hs:
            mm[d] = {"harmonics": hs}
    plate["motion"] = mm
    with open(out, "w") as f:
        f.write("# Written by scripts/%s: %s\n" % (tool, note))
        yaml.safe_dump(scene, f, sort_keys=False, default_flow_style=None, width=100)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--harmonics", type=int, default=1, choices=[1, 2])
    ap.add_argument("--generations", type=int, default=60)
    ap.add_argument("--popsize", type=int, default=10)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--steps", type=int, default=160)
    ap.add_argument("--cycles", type=int, default=20)
    ap.add_argument("--sides", type=int, default=0,
                    help="friction polygon (the scenes' friction_directions); 0 (default): the disc, "
                    "which matches vinci field better than 16")
    ap.add_argument("--average", type=int, default=5)
    ap.add_argument("--powell", type=int, default=1500, help="Powell evaluations after DE")
    ap.add_argument("--objective", default="circle", choices=["circle", "shape", "ring"],
                    help="circle (default): the field error as vinci field-design scores the "
                    "circle (inside and outside each on its own); shape: the whole-field shape "
                    "error; ring: maximize the ring component b")
    ap.add_argument("--min-speed", type=float, default=0.0,
                    help="m/s: a field with a smaller RMS speed is penalized by 1 - speed/min")
    ap.add_argument("--start", help="a plate scene: Powell only, from its motion")
    ap.add_argument("--scan", action="store_true",
                    help="only scan the rotationally symmetric family (translation + wobble)")
    ap.add_argument("--ring", action="store_true",
                    help="scan the symmetric family near the sticking threshold for rings (radial "
                    "velocity outward inside, inward outside); with --powell N refine the best "
                    "ring's x, y, roll, pitch (first harmonics) on the circle error")
    ap.add_argument("--wobble", metavar="U,ALPHA,PSI",
                    help="Powell only, from a circular translation of amplitude U (m) with a "
                    "wobble (roll and pitch in quadrature) of angular acceleration ALPHA (rad/s^2) "
                    "at phase PSI (rad), both at the base frequency")
    ap.add_argument("--write-scene")
    ap.add_argument("--base", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "..",
                                                   "examples/field_design/found/circle.yaml"))
    a = ap.parse_args()
    sl = slots(a.harmonics)
    target = pm.circle_target(pm.GX, pm.GY)
    bounds = [(-1, 1)] * (2 * len(sl))
    if a.ring:
        m = scan_ring(a)
        if m is not None and a.powell > 0:
            sl = [("x", 1), ("y", 1), ("roll", 1), ("pitch", 1)]
            got = {(d, k): (amp, phi) for d, k, amp, phi in m}
            u0 = np.array(sum(([got[s_][0] / BOUND[s_[0]], got[s_][1] / np.pi] for s_ in sl), []))
            a.objective = "circle"
            r = minimize(lambda v: objective_batch(np.clip(v, -1, 1), sl, a, target)[0], u0,
                         method="Powell", options={"maxfev": a.powell, "xtol": 1e-4,
                                                   "ftol": 1e-6})
            m = decode(np.clip(r.x, -1, 1), sl)
            v, _ = pm.transient_field(m, steps=a.steps)
            print("powell: circle error %.4f, ring at %s mm" %
                  (r.fun, ring_radius(v) and "%.1f" % (1e3 * ring_radius(v))))
            for d, k, amp, phi in m:
                print("  %-5s order %d: amplitude %+.4e, phase %+.4f" % (d, k, amp, phi))
        if a.write_scene and m is not None:
            write_scene(a.base, a.write_scene, m, "the best ring of --ring")
        return
    if a.scan:
        m = scan_symmetric(a, target)
        if a.write_scene:
            write_scene(a.base, a.write_scene, m, "the best of --scan")
        return
    if a.start or a.wobble:
        u = start_vector(a.start, sl) if a.start else wobble_vector(a.wobble, sl)
        print("start: model error %.4f" % objective_batch(u, sl, a, target)[0], flush=True)
    else:
        gen = [0]

        def cb(xk, convergence):
            gen[0] += 1
            print("generation %d: best %.4f" % (gen[0], objective_batch(xk, sl, a, target)[0]),
                  flush=True)

        r = differential_evolution(lambda us: objective_batch(us.T, sl, a, target), bounds,
                                   seed=a.seed, maxiter=a.generations, popsize=a.popsize,
                                   tol=1e-8, polish=False, vectorized=True, updating="deferred",
                                   callback=cb)
        u = r.x
        print("differential evolution: %.4f (%d evaluations)" % (r.fun, r.nfev), flush=True)
    if a.powell > 0:
        count = [0, np.inf]

        def f(v):
            e = objective_batch(np.clip(v, -1, 1), sl, a, target)[0]
            count[0] += 1
            count[1] = min(count[1], e)
            if count[0] % 200 == 0:
                print("powell %d: best %.4f" % tuple(count), flush=True)
            return e

        r = minimize(f, u,
                     method="Powell", options={"maxfev": a.powell, "xtol": 1e-4, "ftol": 1e-7})
        u = np.clip(r.x, -1, 1)
        print("powell: %.4f (%d evaluations)" % (r.fun, r.nfev), flush=True)
    m = decode(u, sl)
    err = objective_batch(u, sl, a, target)[0]
    print("best model objective %.4f (steps %d); limits excess %.3f" % (err, a.steps, excess(m)))
    v = batch_error(np.array([u]), sl, argparse.Namespace(**{**vars(a), "objective": "shape"}),
                    target)
    print("its shape error %.4f" % v[0])
    speed = np.sqrt((pm.transient_field(m, steps=a.steps, cycles=a.cycles,
                                        average=a.average)[0]**2).sum(1).mean())
    print("its RMS speed %.4f m/s" % speed)
    for d, k, amp, phi in m:
        print("  %-5s order %d: amplitude %+.4e, phase %+.4f" % (d, k, amp, phi))
    if a.write_scene:
        write_scene(a.base, a.write_scene, m, "model error %.4f" % err)


if __name__ == "__main__":
    main()
