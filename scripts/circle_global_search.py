#!/usr/bin/python3
"""A global search for the circle motion on the transient point model (scripts/
plate_point_model.py; docs/planning.md, "Why not ≤ 0.1"): multi-start CMA-ES over the whole class
the spec format allows at 30 Hz, the first and second harmonics of x, y, z, roll, pitch and yaw
(phases free; x's first phase 0 fixes the time origin: 23 variables), within the limits of
examples/field_design/circle.yaml exactly.

usage: scripts/circle_global_search.py [--starts N] [--generations G] [--popsize L] [--seed S]
                                       [--sides N] [--no-symmetric] [--polish EVALS]
                                       [--top K] [--write-scene OUT.yaml [--spec-family]]
       scripts/circle_global_search.py --score SCENE.yaml [--sides N]

The runs: N random starts near the sticking threshold (the first-harmonic x and y accelerations
0.85-1.3 times mu g, y's phase uniform; roll and pitch uniform up to the angular limit, scaled to
the vertical limit; the other ten slots up to 16% of their limits, phases uniform) plus, unless
--no-symmetric, four seeds on the ring (the shipped circle.yaml and circle_round_cone.yaml motions
and the symmetric ring at the exact limit, both at psi 0.655 and psi 0.655 - 0.3), each a CMA-ES
(full covariance, population L; initial steps for the random starts 0.1 in log-acceleration, 0.3
rad in phase, 0.2 in roll1's and pitch1's u, 0.05 in the other slots' u, 0.3 times that for the
seeds; stopped after G generations or when the step is below 1e-4), all populations evaluated
together (one numpy batch per generation); then Powell (--polish evaluations) from the best K
and from the best random start. The model: --sides N (16: the scenes' pyramid; 0: the disc, the
round cone) with the simulator's normal-impulse timing (plate_point_model.py --normal-lag), 160
steps per cycle, 20 cycles from rest, the last 5 averaged; the error is the spec's (inside and
outside the circle each on its own).

Parametrization (u, unbounded; decode then project): x1, y1: acceleration mu g exp(u) with u
clipped to [ln 0.5, ln 7.6] (7.6 mu g = 15 m/s^2); every other slot: acceleration L sin^2(u)
(L: 15 m/s^2 for x2, y2, z1, z2; 100 rad/s^2 for roll, pitch, yaw), amplitude = acceleration /
(2 pi k f)^2 >= 0. Projection, as vinci field-design checks the limits: per DOF the sum over its
harmonics of (2 pi k f)^2 |A| is scaled down to 15 m/s^2 (x, y, z) or 100 rad/s^2 (roll, pitch,
yaw); then z, roll and pitch together to a peak normal acceleration over the grid's corners
(vertical_peak: exact, 512 samples per period) of 9 (1 - 1e-4) m/s^2 (the sampling misses at
most 8e-5 of a second harmonic's peak).
"""
import argparse
import os
import time

import numpy as np
from scipy.optimize import minimize

import circle_model_search
import circle_rich_search
import plate_point_model as pm

F = 30.0
W = 2 * np.pi * F
STEPS = 160
MUG = pm.MU * pm.G_ACC
SLOTS = [(d, 1) for d in pm.DOFS] + [(d, 2) for d in pm.DOFS]
LIMIT = {"x": 15.0, "y": 15.0, "z": 15.0, "roll": 100.0, "pitch": 100.0, "yaw": 100.0}
VERTICAL = 9.0 * (1 - 1e-4)
LOG_LO, LOG_HI = np.log(0.5), np.log(15.0 / MUG)
# variable layout: (slot, "a" | "p"); x1's phase is fixed at 0
VARS = [(s, c) for s in SLOTS for c in ("a", "p") if (s, c) != (("x", 1), "p")]
N = len(VARS)
STEP0 = np.array([0.1 if s in (("x", 1), ("y", 1)) and c == "a" else 0.3 if c == "p" else
                  0.2 if s in (("roll", 1), ("pitch", 1)) else 0.05 for s, c in VARS])
HERE = os.path.dirname(os.path.abspath(__file__))


def dof_peaks(motion):
    return {d: sum((W * k)**2 * abs(a) for dd, k, a, _ in motion if dd == d) for d in pm.DOFS}


def project(motion):
    """The motion scaled into the limits (module docstring)."""
    peaks = dof_peaks(motion)
    m = [(d, k, a * min(1.0, LIMIT[d] / peaks[d]) if peaks[d] > 0 else a, p)
         for d, k, a, p in motion]
    peak = circle_rich_search.exact_peak(m, F)
    if peak > VERTICAL:
        s = VERTICAL / peak
        m = [(d, k, a * s if d in ("z", "roll", "pitch") else a, p) for d, k, a, p in m]
    return m


def decode(u):
    amp, phase = {}, {s: 0.0 for s in SLOTS}
    for (s, c), x in zip(VARS, u):
        if c == "p":
            phase[s] = float(x)
            continue
        d, k = s
        if k == 1 and d in ("x", "y"):
            acc = MUG * np.exp(np.clip(x, LOG_LO, LOG_HI))
        else:
            acc = LIMIT[d] * np.sin(x)**2
        amp[s] = float(acc) / (W * k)**2
    return project([(d, k, amp[(d, k)], phase[(d, k)]) for d, k in SLOTS])


def encode(motion):
    """u of a motion [(dof, order, amplitude, phase)] (amplitudes made >= 0 by a phase of pi)."""
    m = {(d, k): (a, p) if a >= 0 else (-a, p + np.pi) for d, k, a, p in motion}
    u = []
    for s, c in VARS:
        a, p = m.get(s, (0.0, 0.0))
        if c == "p":
            u.append(np.angle(np.exp(1j * p)))
            continue
        acc = a * (W * s[1])**2
        if s[1] == 1 and s[0] in ("x", "y"):
            u.append(np.log(max(acc, 1e-12) / MUG))
        else:
            u.append(np.arcsin(np.sqrt(min(1.0, acc / LIMIT[s[0]]))))
    return np.array(u)


def friction_polygon(ux, uy, cap, sides, cos_t, sin_t):
    """plate_point_model.friction_step's relative velocity after the impulse (u - its projection
    onto the friction set), with the polygon's vertices from tables."""
    if sides == 0:
        u = np.hypot(ux, uy)
        s = np.where(u > cap, 1.0 - cap / np.maximum(u, 1e-300), 0.0)
        return s * ux, s * uy
    k = np.floor(np.arctan2(uy, ux) * (sides / (2 * np.pi))).astype(np.int64) % sides
    ax, ay = cap * cos_t[k], cap * sin_t[k]
    bx, by = cap * cos_t[k + 1], cap * sin_t[k + 1]
    ex, ey = bx - ax, by - ay
    t = np.clip(((ux - ax) * ex + (uy - ay) * ey) / np.maximum(ex * ex + ey * ey, 1e-300), 0, 1)
    px, py = ax + t * ex, ay + t * ey
    inside = ((ux - ax) * ey - (uy - ay) * ex) * (-(ax * ey - ay * ex)) >= 0
    return np.where(inside, 0.0, ux - px), np.where(inside, 0.0, uy - py)


def fields(motions, sides=16, cycles=20, average=5):
    """The transient model's fields (P, 121, 2) with the normal force at each step's start
    (plate_point_model.transient_field(..., normal_lag=True)), vectorized over motions; the plate's
    signals are periodic, so one cycle of them serves every cycle."""
    h = 1.0 / F / STEPS
    t = (np.arange(STEPS) + 1) * h
    P = len(motions)
    sig = np.zeros((8, STEPS, P, 1))
    for j, m in enumerate(motions):
        rate, _, angle = pm.plate_signals(m, t, F)
        acc = pm.plate_signals(m, t - h, F)[1]
        for i, s in enumerate((rate["x"], rate["y"], rate["yaw"], acc["z"], acc["roll"],
                               acc["pitch"], angle["pitch"], angle["roll"])):
            sig[i, :, j, 0] = s
    rx, ry, ryaw, az, aroll, apitch, gpitch, groll = sig
    cos_t = np.cos(2 * np.pi * np.arange(sides + 1) / max(sides, 1))
    sin_t = np.sin(2 * np.pi * np.arange(sides + 1) / max(sides, 1))
    x = np.tile(pm.GX, (P, 1))
    y = np.tile(pm.GY, (P, 1))
    vx, vy = np.zeros_like(x), np.zeros_like(x)
    sx, sy = np.zeros_like(x), np.zeros_like(x)
    start = (cycles - average) * STEPS
    for i in range(cycles * STEPS):
        j = i % STEPS
        n = np.maximum(pm.G_ACC + az[j] + aroll[j] * y - apitch[j] * x, 0.0)
        vx = vx + h * n * gpitch[j]
        vy = vy - h * n * groll[j]
        vpx = rx[j] - ryaw[j] * y
        vpy = ry[j] + ryaw[j] * x
        ux, uy = friction_polygon(vx - vpx, vy - vpy, pm.MU * n * h, sides, cos_t, sin_t)
        vx, vy = vpx + ux, vpy + uy
        x, y = x + h * vx, y + h * vy
        if i >= start:
            sx, sy = sx + vx, sy + vy
    return np.stack([sx, sy], 2) / (average * STEPS)


TARGET = pm.circle_target(pm.GX, pm.GY)
INSIDE = pm.GX**2 + pm.GY**2 < 0.05**2


def errors(v):
    """(error, inside, outside) of one field (121, 2), as vinci field-design scores the circle."""
    e_in = pm.shape_error(v[INSIDE], TARGET[INSIDE])
    e_out = pm.shape_error(v[~INSIDE], TARGET[~INSIDE])
    return float(np.sqrt(0.5 * (e_in**2 + e_out**2))), e_in, e_out


class Cma:
    """CMA-ES (Hansen's tutorial, full covariance, rank-one and rank-mu updates) in the variables
    u = mean + sigma * STEP0 * y, y ~ N(0, C)."""

    def __init__(self, mean, f0, lam, rng, sigma=1.0):
        n = len(mean)
        self.n, self.lam, self.rng = n, lam, rng
        self.mean, self.sigma = np.array(mean, float), sigma
        self.mu = lam // 2
        w = np.log(self.mu + 0.5) - np.log(np.arange(1, self.mu + 1))
        self.w = w / w.sum()
        self.mueff = 1.0 / (self.w**2).sum()
        me = self.mueff
        self.cc = (4 + me / n) / (n + 4 + 2 * me / n)
        self.cs = (me + 2) / (n + me + 5)
        self.c1 = 2 / ((n + 1.3)**2 + me)
        self.cmu = min(1 - self.c1, 2 * (me - 2 + 1 / me) / ((n + 2)**2 + me))
        self.damps = 1 + 2 * max(0, np.sqrt((me - 1) / (n + 1)) - 1) + self.cs
        self.chin = np.sqrt(n) * (1 - 1 / (4 * n) + 1 / (21 * n * n))
        self.pc, self.ps, self.C = np.zeros(n), np.zeros(n), np.eye(n)
        self.D = np.ones(n)
        self.gen = 0
        self.best = (float(f0), self.mean.copy())

    def ask(self):
        d2, self.B = np.linalg.eigh(self.C)
        self.D = np.sqrt(np.maximum(d2, 1e-20))
        self.z = self.rng.standard_normal((self.lam, self.n))
        self.y = self.z @ (self.B * self.D).T
        return self.mean + self.sigma * STEP0 * self.y

    def tell(self, f):
        order = np.argsort(f)
        if f[order[0]] < self.best[0]:
            self.best = (float(f[order[0]]), self.mean + self.sigma * STEP0 * self.y[order[0]])
        ys = self.y[order[:self.mu]]
        zs = self.z[order[:self.mu]]
        yw = self.w @ ys
        self.mean = self.mean + self.sigma * STEP0 * yw
        self.ps = (1 - self.cs) * self.ps + np.sqrt(self.cs * (2 - self.cs) * self.mueff) * (
            self.B @ (self.w @ zs))
        self.gen += 1
        hsig = (np.linalg.norm(self.ps) / np.sqrt(1 - (1 - self.cs)**(2 * self.gen)) / self.chin <
                1.4 + 2 / (self.n + 1))
        self.pc = (1 - self.cc) * self.pc + hsig * np.sqrt(self.cc * (2 - self.cc) *
                                                             self.mueff) * yw
        self.C = ((1 - self.c1 - self.cmu) * self.C +
                  self.c1 * (np.outer(self.pc, self.pc) +
                             (1 - hsig) * self.cc * (2 - self.cc) * self.C) +
                  self.cmu * (ys.T * self.w) @ ys)
        self.sigma *= np.exp(self.cs / self.damps * (np.linalg.norm(self.ps) / self.chin - 1))

    def done(self, tol=1e-4):
        return self.sigma * self.D.max() < tol


def random_start(rng):
    u = np.zeros(N)
    for i, (s, c) in enumerate(VARS):
        if c == "p":
            u[i] = rng.uniform(-np.pi, np.pi)
        elif s in (("x", 1), ("y", 1)):
            u[i] = np.log(rng.uniform(0.85, 1.3))
        elif s in (("roll", 1), ("pitch", 1)):
            u[i] = np.arcsin(np.sqrt(rng.uniform(0, 1)))
        else:
            u[i] = rng.uniform(-0.4, 0.4)
    return u


def symmetric_seeds():
    out = []
    for name in ("circle.yaml", "circle_round_cone.yaml"):
        m, _ = pm.scene_motion(os.path.join(HERE, "../examples/field_design/found", name))
        out.append(("shipped " + name, encode(m)))
    thr = MUG / W**2
    tilt = 63.6 / W**2
    for psi in (0.655, 0.355):  # the symmetric ring at the exact limit (sense -1) and off it
        m = [("x", 1, thr, 0.0), ("y", 1, -thr, -np.pi / 2), ("roll", 1, -tilt, psi),
             ("pitch", 1, -tilt, psi + np.pi / 2)]
        out.append(("symmetric psi %.3f" % psi, encode(m)))
    return out


def evaluate(us, sides):
    ms = [decode(u) for u in us]
    return np.array([errors(v)[0] for v in fields(ms, sides)])


def describe(m, sides):
    e, ei, eo = errors(fields([m], sides)[0])
    return "%.4f (inside %.4f, outside %.4f)" % (e, ei, eo)


def print_motion(m):
    pk = dof_peaks(m)
    print("    peaks: normal %.4f m/s^2 (corners), %s" %
          (circle_rich_search.exact_peak(m, F, 4096),
           ", ".join("%s %.3g" % (d, pk[d]) for d in pm.DOFS)))
    for d, k, a, p in m:
        if a > 0:
            print("    %-5s order %d: amplitude %.4e, phase %+.4f" % (d, k, a, p))


def summary(m):
    """The motion's ring terms in a line: the first-harmonic translation over the threshold, y's
    phase, the wobble's angular accelerations and phases, and the largest of the other terms."""
    mm = {(d, k): (a, p) for d, k, a, p in m}
    ring = [("x", 1), ("y", 1), ("roll", 1), ("pitch", 1)]
    rest = max((W * k)**2 * abs(a) * (0.1 if d in ("roll", "pitch", "yaw") else 1.0)
               for d, k, a, _ in m if (d, k) not in ring)
    return ("x %.3f, y %.3f mu g (phase %+.2f), roll %.1f (%+.2f), pitch %.1f (%+.2f) rad/s^2; "
            "others <= %.3f m/s^2" % (
                mm[("x", 1)][0] * W**2 / MUG, mm[("y", 1)][0] * W**2 / MUG, mm[("y", 1)][1],
                mm[("roll", 1)][0] * W**2, mm[("roll", 1)][1], mm[("pitch", 1)][0] * W**2,
                mm[("pitch", 1)][1], rest))


def run(a):
    rng = np.random.default_rng(a.seed)
    starts = [("random %d" % i, random_start(rng)) for i in range(a.starts)]
    if not a.no_symmetric:
        starts += symmetric_seeds()
    e0 = evaluate([u for _, u in starts], a.sides)
    runs = [Cma(u, e, a.popsize, np.random.default_rng([a.seed, i]),
                1.0 if name.startswith("random") else 0.3)
            for i, ((name, u), e) in enumerate(zip(starts, e0))]
    t0, nev = time.process_time(), len(starts)
    for g in range(a.generations):
        live = [r for r in runs if not r.done()]
        if not live:
            break
        xs = [r.ask() for r in live]
        f = evaluate(np.concatenate(xs), a.sides)
        nev += len(f)
        for i, r in enumerate(live):
            r.tell(f[i * a.popsize:(i + 1) * a.popsize])
        if g % 10 == 9:
            b = sorted(r.best[0] for r in runs)
            print("generation %d: %d runs live, %d evaluations, %.0f s CPU; best %.4f, median of "
                  "the runs' bests %.4f" % (g + 1, len(live), nev, time.process_time() - t0, b[0],
                                            np.median(b)), flush=True)
    print("\nCMA-ES, %d runs (popsize %d), %d evaluations, %.0f s CPU; per run (start -> best):" %
          (len(runs), a.popsize, nev, time.process_time() - t0))
    res = sorted(((r.best[0], name, e, r) for (name, _), e, r in zip(starts, e0, runs)),
                 key=lambda t: t[0])
    for best, name, e, r in res:
        print("  %-22s %.4f -> %.4f (%3d generations): %s" % (name, e, best, r.gen,
                                                             summary(decode(r.best[1]))))
    rnd = [b for b, name, _, _ in res if name.startswith("random")]
    if rnd:
        print("random starts: best %.4f, median %.4f, %d of %d below 0.15" %
              (min(rnd), np.median(rnd), sum(b < 0.15 for b in rnd), len(rnd)))
    out = []
    polish = res[:a.top]
    if rnd and not any(name.startswith("random") for _, name, _, _ in polish):
        polish.append(next(t for t in res if t[1].startswith("random")))
    for best, name, _, r in polish:
        u = r.best[1]
        count = [0]

        def obj(v):
            count[0] += 1
            return evaluate([v], a.sides)[0]

        t1 = time.process_time()
        p = minimize(obj, u, method="Powell", options={"maxfev": a.polish, "xtol": 1e-4,
                                                         "ftol": 1e-6})
        m = decode(p.x)
        print("\nPowell from %s (%.4f): %.4f after %d evaluations (%.0f s CPU); sides %d: %s, "
              "the other model (sides %d): %s" %
              (name, best, p.fun, count[0], time.process_time() - t1, a.sides,
               describe(m, a.sides), 16 - a.sides, describe(m, 16 - a.sides)))
        print_motion(m)
        out.append((p.fun, name, m))
    out.sort(key=lambda t: t[0])
    return out


def spec_family(m):
    """The motion's terms in circle.yaml's parametrization: the first harmonics of x, y, z, roll
    and pitch (the rest dropped), with its signs (y, z and roll amplitudes negative, phases
    shifted by pi) so that a `vinci field-design --start` finds them within the box."""
    out = []
    for d, k, amp, phi in m:
        if k != 1 or d == "yaw":
            continue
        if d in ("y", "z", "roll") and amp > 0:
            amp, phi = -amp, phi - np.pi if phi > 0 else phi + np.pi
        out.append((d, k, amp, float(np.angle(np.exp(1j * phi)))))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--starts", type=int, default=40)
    ap.add_argument("--generations", type=int, default=120)
    ap.add_argument("--popsize", type=int, default=12)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--sides", type=int, default=16, choices=[0, 16],
                    help="the model's friction set: 16 (the scenes' pyramid) or 0 (the disc)")
    ap.add_argument("--no-symmetric", action="store_true", help="random starts only")
    ap.add_argument("--polish", type=int, default=600, help="Powell evaluations per polished run")
    ap.add_argument("--top", type=int, default=2, help="polish the best K runs")
    ap.add_argument("--write-scene", help="write the best motion as a plate scene")
    ap.add_argument("--spec-family", action="store_true",
                    help="--write-scene: only the terms of circle.yaml's parametrization, in its "
                    "signs (a start for vinci field-design --start)")
    ap.add_argument("--score", help="only score a plate scene's motion (both friction sets)")
    a = ap.parse_args()
    if a.score:
        m, _ = pm.scene_motion(a.score)
        print("sides 16: %s; disc: %s" % (describe(m, 16), describe(m, 0)))
        print("projected (unchanged if within the limits): sides 16: %s" %
              describe(project(m), 16))
        print_motion(m)
        return
    out = run(a)
    if a.write_scene and out:
        e, name, m = out[0]
        if a.spec_family:
            m = spec_family(m)
            print("the spec's family: sides %d: %s" % (a.sides, describe(m, a.sides)))
        circle_model_search.write_scene(
            os.path.join(HERE, "../examples/field_design/found",
                         "circle.yaml" if a.sides else "circle_round_cone.yaml"), a.write_scene,
            [t for t in m if t[2] != 0], "global search (seed %d, from %s), model error %.4f "
            "(sides %d, normal lag)" % (a.seed, name, e, a.sides), frequency=F,
            tool="circle_global_search.py")


if __name__ == "__main__":
    main()
