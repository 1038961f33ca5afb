#!/usr/bin/env python3
"""Independent check of the Kepler reference points of issue 5 (pure Python, no ballfield code).

Worst relative energy error over 100 orbits of the one-body Kepler problem (mu = 1, a = 1,
started at periapsis), for symplectic Euler, leapfrog in both of its forms, and RK4:

    python3 docs/accuracy/kepler_reference.py      # takes about a minute

Leapfrog kick-drift-kick (velocity Verlet) gives the issue's figures (1.1e-4 and 4e-6);
drift-kick-drift, the form ballfield uses, gives about a quarter of them (2.5e-5 and 9.7e-7):
the same method sampled at other points, with the energy measured where x and v are in step.
The two-body problem in ballfield reduces to this one for the relative coordinate, and the
relative energy error does not depend on the mass ratio.
"""
import math


def acc(x, y):
    r2 = x * x + y * y
    f = -1.0 / (r2 * math.sqrt(r2))
    return f * x, f * y


def energy(x, y, vx, vy):
    return 0.5 * (vx * vx + vy * vy) - 1.0 / math.sqrt(x * x + y * y)


def worst_energy_error(method, e, steps_per_orbit, orbits=100):
    x, y = 1.0 - e, 0.0
    vx, vy = 0.0, math.sqrt((1.0 + e) / (1.0 - e))
    h = 2.0 * math.pi / steps_per_orbit
    e0 = energy(x, y, vx, vy)
    worst = 0.0
    for _ in range(steps_per_orbit * orbits):
        if method == "symplectic-euler":
            ax, ay = acc(x, y)
            vx += h * ax; vy += h * ay
            x += h * vx; y += h * vy
        elif method == "leapfrog-kdk":
            ax, ay = acc(x, y)
            vx += 0.5 * h * ax; vy += 0.5 * h * ay
            x += h * vx; y += h * vy
            ax, ay = acc(x, y)
            vx += 0.5 * h * ax; vy += 0.5 * h * ay
        elif method == "leapfrog-dkd":
            x += 0.5 * h * vx; y += 0.5 * h * vy
            ax, ay = acc(x, y)
            vx += h * ax; vy += h * ay
            x += 0.5 * h * vx; y += 0.5 * h * vy
        elif method == "rk4":
            def f(s):
                ax, ay = acc(s[0], s[1])
                return (s[2], s[3], ax, ay)
            s = (x, y, vx, vy)
            k1 = f(s)
            k2 = f(tuple(s[i] + 0.5 * h * k1[i] for i in range(4)))
            k3 = f(tuple(s[i] + 0.5 * h * k2[i] for i in range(4)))
            k4 = f(tuple(s[i] + h * k3[i] for i in range(4)))
            x, y, vx, vy = (s[i] + h / 6.0 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]) for i in range(4))
        worst = max(worst, abs((energy(x, y, vx, vy) - e0) / e0))
    return worst


if __name__ == "__main__":
    for e, spo, reference in [(0.5, 1000, "9e-3, 1.1e-4, 3e-8"), (0.0, 100, "4e-3, 4e-6, 1.7e-5")]:
        print(f"e = {e}, {spo} steps per orbit, 100 orbits (issue: {reference})")
        for m in ["symplectic-euler", "leapfrog-kdk", "leapfrog-dkd", "rk4"]:
            print(f"  {m:<17} {worst_energy_error(m, e, spo):.2e}")
