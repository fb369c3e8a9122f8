#!/usr/bin/python3
"""A transient point model of a part on the vibrating plate (docs/planning.md, "The circle target
and its floor"): the cheap stand-in for `vinci field` used to screen circle motions.

usage: scripts/plate_point_model.py SCENE.yaml [--field FIELD.csv] [--cycles K] [--average N]
                                               [--steps S] [--profile] [--sides N]
                                               [--normal-lag]
                                               [--trajectories SECONDS [--plot PNG]]

For SCENE's plate motion (a `vinci field-design` best.yaml or any plate scene with harmonics) it
prints, on the specs' 11x11 grid over [-0.1, 0.1]^2, the circle target's shape error (R = 5 cm) of
  1. the cycle-averaged theory (plate_theory.h's model: the part's velocity constant within a
     cycle, measured where it starts), and
  2. the transient model: a point part started at rest at each grid point, integrated for K
     cycles with the simulator's time step h = T/S and its velocity averaged over the last N
     cycles (what `vinci field` measures, including the drift of the part during the run),
and with --field, the simulated field's error and the RMS difference between each model and the
simulation (both normalized by the simulation's RMS speed).

The transient model, per time step (semi-implicit, like the simulator's time stepping, but with
the exact friction disc where the scenes use a 16-sided pyramid): the plate point under the part
p moves with v_p = (xdot - yawdot y, ydot + yawdot x); the normal force per unit mass is
n = g + zddot + rollddot y - pitchddot x (small angles; n > 0 within the specs' vertical limit);
the tilt adds n (pitch, -roll) to the part's horizontal acceleration; the friction impulse per
unit mass is at most mu n h: if the part's velocity relative to the plate after the tilt impulse
is within that, it sticks (v = v_p), else it slides with the relative velocity reduced by mu n h
along itself. Every DOF is A (sin(2 pi k f t + phi) - sin(phi)) as in the scene format.
--sides N replaces the disc by the regular N-gon inscribed in it (a `friction_directions: N`
pyramid); --normal-lag takes the normal force from the plate's acceleration at the start of the
step instead of its end: like the simulator's normal impulse, which the model then reproduces to
~1% on the round cone (docs/planning.md, "The friction cone and the time step").
"""
import argparse

import numpy as np

G_ACC = 9.81
MU = 0.2
F = 30.0
DOFS = ["x", "y", "z", "roll", "pitch", "yaw"]
GRID = np.linspace(-0.1, 0.1, 11)
GX, GY = (a.ravel() for a in np.meshgrid(GRID, GRID))


def circle_target(x, y, radius=0.05):
    """The circle target of planning/src/field_design_spec.cc (counter-clockwise, s = 1)."""
    q = (x**2 + y**2) / radius**2
    ratio = (1 - q) / (1 + q)
    return np.stack([(-y + ratio * x) / radius, (x + ratio * y) / radius], 1)


def shape_error(v, t):
    sv = np.sqrt((v**2).sum(1).mean())
    st = np.sqrt((t**2).sum(1).mean())
    return 1.0 if sv == 0 else float(np.sqrt(((v / sv - t / st)**2).sum(1).mean()))


def circle_error(v, x=GX, y=GY, radius=0.05):
    """The circle's field error as vinci field-design scores it (FieldError with the target's
    regions): the shape error inside (rho < R) and outside, each on its own, RMS of the two."""
    t = circle_target(x, y, radius)
    inside = x**2 + y**2 < radius**2
    return float(np.sqrt(0.5 * (shape_error(v[inside], t[inside])**2 +
                                shape_error(v[~inside], t[~inside])**2)))


def circle_sides(v, x=GX, y=GY, radius=0.05):
    """The circle's shape error inside (rho < R) and outside, each on its own."""
    t = circle_target(x, y, radius)
    inside = x**2 + y**2 < radius**2
    return shape_error(v[inside], t[inside]), shape_error(v[~inside], t[~inside])


def radial_profile(v, x=GX, y=GY):
    """[(rho, n, mean v_r, mean v_t)] over the grid's rings of equal rho (m, m/s)."""
    rho = np.hypot(x, y)
    th = np.arctan2(y, x)
    vr = v[:, 0] * np.cos(th) + v[:, 1] * np.sin(th)
    vt = -v[:, 0] * np.sin(th) + v[:, 1] * np.cos(th)
    out = []
    for r in np.unique(np.round(rho, 6)):
        k = np.abs(rho - r) < 1e-6
        out.append((float(r), int(k.sum()), float(vr[k].mean()), float(vt[k].mean())))
    return out


def print_profile(name, v, x=GX, y=GY):
    print("%s: radial profile (rho mm: v_r, v_t mm/s; v_r/|v_t|)" % name)
    for r, n, vr, vt in radial_profile(v, x, y):
        if r > 0:
            print("  %5.1f (%2d): %+7.3f %+7.3f  %+.2f" % (1e3 * r, n, 1e3 * vr, 1e3 * vt,
                                                       vr / max(abs(vt), 1e-12)))


def scene_motion(path):
    """[(dof, order, amplitude, phase)] of a scene file's first prescribed body; its frequency."""
    import yaml
    scene = yaml.safe_load(open(path))
    plate = next(b for b in scene["bodies"] if b.get("kind") == "prescribed")
    out = []
    for dof in DOFS:
        for i, h in enumerate(plate["motion"].get(dof, {}).get("harmonics", [])):
            out.append((dof, int(h.get("order", i + 1)), float(h["amplitude"]), float(h["phase"])))
    return out, float(plate["motion"]["frequency"])


def plate_signals(motion, t, f=F):
    """Per DOF: rate and acceleration at the times t (arrays)."""
    rate = {d: np.zeros_like(t) for d in DOFS}
    acc = {d: np.zeros_like(t) for d in DOFS}
    for dof, k, a, phi in motion:
        w = 2 * np.pi * f * k
        rate[dof] = rate[dof] + a * w * np.cos(w * t + phi)
        acc[dof] = acc[dof] - a * w * w * np.sin(w * t + phi)
    angle = {d: np.zeros_like(t) for d in ("roll", "pitch")}
    for dof, k, a, phi in motion:
        if dof in angle:
            w = 2 * np.pi * f * k
            angle[dof] = angle[dof] + a * (np.sin(w * t + phi) - np.sin(phi))
    return rate, acc, angle


def friction_step(vx, vy, vpx, vpy, cap, sides=0):
    """The part's velocity after one step's friction impulse (per unit mass at most cap), from its
    velocity (vx, vy) and the plate point's (vpx, vpy): the relative velocity u minus its
    projection onto the friction set (maximal dissipation with the implicit velocity, as the
    simulator's time stepping for a point mass). The set is the disc of radius cap (sides = 0) or,
    like the scenes' `friction_directions: sides` pyramid, the regular polygon inscribed in it with
    vertices at the angles 2 pi k / sides."""
    ux, uy = vx - vpx, vy - vpy
    if sides == 0:
        u = np.hypot(ux, uy)
        scale = np.where(u > cap, 1.0 - cap / np.maximum(u, 1e-300), 0.0)
        return vpx + scale * ux, vpy + scale * uy
    step = 2 * np.pi / sides
    k = np.floor(np.arctan2(uy, ux) / step)
    ax, ay = cap * np.cos(k * step), cap * np.sin(k * step)  # the edge of u's wedge: a to b
    bx, by = cap * np.cos((k + 1) * step), cap * np.sin((k + 1) * step)
    ex, ey = bx - ax, by - ay
    t = np.clip(((ux - ax) * ex + (uy - ay) * ey) / np.maximum(ex * ex + ey * ey, 1e-300), 0, 1)
    px, py = ax + t * ex, ay + t * ey  # the nearest point of the edge
    # inside the polygon (u on the origin's side of the edge): the part sticks
    inside = ((ux - ax) * ey - (uy - ay) * ex) * (-(ax * ey - ay * ex)) >= 0
    rx, ry = np.where(inside, 0.0, ux - px), np.where(inside, 0.0, uy - py)
    return vpx + rx, vpy + ry


def transient_field(motion, x0=GX, y0=GY, cycles=20, average=5, steps=160, f=F, mu=MU,
                    sides=0, normal_lag=False):
    """The transient point model (module docstring): average velocity over the last `average` of
    `cycles` cycles of a part started at rest at (x0, y0); also its mean position there. With
    normal_lag the normal force uses the plate's acceleration at the start of each step."""
    h = 1.0 / f / steps
    t = (np.arange(cycles * steps) + 1) * h  # the end of each step (the simulator's velocities)
    rate, acc, angle = plate_signals(motion, t, f)
    if normal_lag:
        acc = plate_signals(motion, t - h, f)[1]
    x, y = np.array(x0, float), np.array(y0, float)
    vx, vy = np.zeros_like(x), np.zeros_like(x)
    sx, sy, px, py, n_avg = 0.0, 0.0, 0.0, 0.0, 0
    start = (cycles - average) * steps
    for i in range(cycles * steps):
        n = G_ACC + acc["z"][i] + acc["roll"][i] * y - acc["pitch"][i] * x
        n = np.maximum(n, 0.0)
        vx = vx + h * n * angle["pitch"][i]
        vy = vy - h * n * angle["roll"][i]
        vpx = rate["x"][i] - rate["yaw"][i] * y
        vpy = rate["y"][i] + rate["yaw"][i] * x
        vx, vy = friction_step(vx, vy, vpx, vpy, mu * n * h, sides)
        x, y = x + h * vx, y + h * vy
        if i >= start:
            sx, sy, px, py, n_avg = sx + vx, sy + vy, px + x, py + y, n_avg + 1
    return np.stack([sx / n_avg, sy / n_avg], 1), np.stack([px / n_avg, py / n_avg], 1)


def trajectories(motion, rho0, seconds, steps=160, f=F, mu=MU):
    """The transient model's paths of parts started at rest at (rho0, 0): positions (cycles + 1,
    n, 2) once per cycle."""
    h = 1.0 / f / steps
    x, y = np.array(rho0, float), np.zeros(len(rho0))
    vx, vy = np.zeros_like(x), np.zeros_like(x)
    t1 = (np.arange(steps) + 1) * h
    rate, acc, angle = plate_signals(motion, t1, f)  # periodic: one cycle serves them all
    path = [np.stack([x, y], 1)]
    for _ in range(int(round(seconds * f))):
        for i in range(steps):
            n = np.maximum(G_ACC + acc["z"][i] + acc["roll"][i] * y - acc["pitch"][i] * x, 0.0)
            vx = vx + h * n * angle["pitch"][i]
            vy = vy - h * n * angle["roll"][i]
            vx, vy = friction_step(vx, vy, rate["x"][i] - rate["yaw"][i] * y,
                                   rate["y"][i] + rate["yaw"][i] * x, mu * n * h)
            x, y = x + h * vx, y + h * vy
        path.append(np.stack([x, y], 1))
    return np.array(path)


def theory_field(motion, x0=GX, y0=GY, samples=64, f=F, mu=MU, iterations=80):
    """The cycle-averaged theory (plate_theory.h's force balance; tilt neglected): Weiszfeld."""
    t = (np.arange(samples) + 0.5) / samples / f
    rate, acc, _ = plate_signals(motion, t, f)
    vpx = rate["x"][None, :] - rate["yaw"][None, :] * y0[:, None]
    vpy = rate["y"][None, :] + rate["yaw"][None, :] * x0[:, None]
    n = np.maximum(0.0, G_ACC + acc["z"][None, :] + acc["roll"][None, :] * y0[:, None] -
                   acc["pitch"][None, :] * x0[:, None])
    v = np.stack([(n * vpx).sum(1), (n * vpy).sum(1)], 1) / np.maximum(n.sum(1), 1e-12)[:, None]
    for _ in range(iterations):
        d = np.sqrt((v[:, :1] - vpx)**2 + (v[:, 1:] - vpy)**2 + 1e-14)
        w = n / d
        v = np.stack([(w * vpx).sum(1), (w * vpy).sum(1)], 1) / np.maximum(w.sum(1), 1e-30)[:, None]
    return v


def read_field(path):
    import csv
    rows = list(csv.DictReader(open(path)))
    return (np.array([[float(r["x"]), float(r["y"])] for r in rows]),
            np.array([[float(r["vx"]), float(r["vy"])] for r in rows]))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--field")
    ap.add_argument("--cycles", type=int, default=20)
    ap.add_argument("--average", type=int, default=5)
    ap.add_argument("--steps", type=int, default=160)
    ap.add_argument("--profile", action="store_true",
                    help="print the radial profile v_r(rho), v_t(rho) of the transient model (and "
                    "of the simulation with --field): a ring has v_r > 0 inside, < 0 outside")
    ap.add_argument("--trajectories", metavar="SECONDS", type=float,
                    help="also integrate parts started at 1, 3, 7, 9, 12 cm for SECONDS with the "
                    "transient model, print their distance from the centre and (with --plot PNG) "
                    "draw their paths with the circle R = 5 cm")
    ap.add_argument("--plot", metavar="PNG")
    ap.add_argument("--sides", type=int, default=0,
                    help="friction polygon of N sides (a friction_directions: N pyramid) instead "
                    "of the disc (0)")
    ap.add_argument("--normal-lag", action="store_true",
                    help="normal force from the plate's acceleration at the start of each step")
    a = ap.parse_args()
    motion, f = scene_motion(a.scene)
    if a.trajectories:
        rho0 = np.array([0.01, 0.03, 0.07, 0.09, 0.12])
        path = trajectories(motion, rho0, a.trajectories, steps=a.steps, f=f)
        rho = np.hypot(path[:, :, 0], path[:, :, 1])
        for k in range(0, len(path), max(1, int(round(f * a.trajectories / 10)))):
            print("t %6.1f s: rho (mm) %s" % (k / f, " ".join("%6.1f" % (1e3 * r) for r in rho[k])))
        if a.plot:
            import matplotlib
            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
            fig, ax = plt.subplots(1, 2, figsize=(11, 5))
            th = np.linspace(0, 2 * np.pi, 200)
            ax[0].plot(0.05 * np.cos(th), 0.05 * np.sin(th), "k--", lw=1, label="R = 5 cm")
            t = np.arange(len(path)) / f
            for j in range(len(rho0)):
                ax[0].plot(path[:, j, 0], path[:, j, 1], lw=1)
                ax[0].plot(path[0, j, 0], path[0, j, 1], "ko", ms=3)
                ax[1].plot(t, 1e3 * rho[:, j])
            ax[1].axhline(50, color="k", ls="--", lw=1)
            ax[0].set_aspect("equal")
            ax[0].set_xlabel("x (m)")
            ax[0].set_ylabel("y (m)")
            ax[0].set_title("paths from rest (transient point model)")
            ax[1].set_xlabel("t (s)")
            ax[1].set_ylabel("distance from the centre (mm)")
            fig.suptitle(a.scene)
            fig.tight_layout()
            fig.savefig(a.plot, dpi=90)
        return
    tg = circle_target(GX, GY)
    th = theory_field(motion, f=f)
    tr, where = transient_field(motion, cycles=a.cycles, average=a.average, steps=a.steps, f=f,
                                sides=a.sides, normal_lag=a.normal_lag)
    print("circle error (inside/outside): theory %.3f, transient model %.3f (inside %.3f, "
          "outside %.3f)" % (circle_error(th), circle_error(tr), *circle_sides(tr)))
    print("whole-field shape error: theory %.3f, transient model %.3f" %
          (shape_error(th, tg), shape_error(tr, tg)))
    if a.profile:
        print_profile("transient model", tr)
    drift = np.hypot(where[:, 0] - GX, where[:, 1] - GY)
    print("transient model: RMS speed %.4f m/s, drift of the averaging window's mean position "
          "from the start: median %.1f mm, max %.1f mm" %
          (np.sqrt((tr**2).sum(1).mean()), 1e3 * np.median(drift), 1e3 * drift.max()))
    if a.field:
        pts, sim = read_field(a.field)
        s = np.sqrt((sim**2).sum(1).mean())
        print("simulation: circle error %.3f (inside %.3f, outside %.3f; whole-field shape error "
              "%.3f), RMS speed %.4f m/s" %
              (circle_error(sim, pts[:, 0], pts[:, 1]), *circle_sides(sim, pts[:, 0], pts[:, 1]),
               shape_error(sim, circle_target(pts[:, 0], pts[:, 1])), s))
        if a.profile:
            print_profile("simulation", sim, pts[:, 0], pts[:, 1])
        for name, v in (("theory", th), ("transient", tr)):
            print("  %s vs simulation: RMS difference / simulated RMS speed %.3f, shape error "
                  "between them %.3f" % (name, np.sqrt(((v - sim)**2).sum(1).mean()) / s,
                                         shape_error(v, sim)))


if __name__ == "__main__":
    main()
