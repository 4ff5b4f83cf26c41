# SPDX-License-Identifier: Apache-2.0
"""The leg estimate: how fast any planner with given per-axis limits could run a program's
straight legs between sharp corners (docs/benchmarks-linuxcnc.md, "What the jerk limit
costs").

A leg is a straight run (collinear G0/G1 pieces) whose both ends are a corner of 90
degrees or more, an exact stop, or the program's start or end. At such a corner the next
leg's direction u has no component along the old one, so the motion's component along u
(q = u . x) must start from a standstill within the corner's tolerance band: while the
tool runs the old leg within P of it, q stays within [-P, P] of the corner. The fastest q
can leave that band is confined_exit(P, a, J): a 1-D motion with |q''| <= a, |q'''| <= J
that drops from the top of the band and swings back up through it (jerk -J, then +J). Along
u the axis limits allow at most a ||u||_1 and J ||u||_1 (each axis contributes its own), and
the path speed at most min(F, v_axis ||u||_1). The leg, shortened by P at each end, is then
at least the time-optimal 1-D move from that entry speed to that exit speed, starting and
ending its ramps with the acceleration already at its limit (optimistic: only the
acceleration's fall to zero at cruise costs a / (2 J) per ramp). Legs are summed; arcs,
gentle corners (< 90 degrees) and what lies between are counted as taking no time.

So the estimate undercounts wherever it can. It is not a proof (the band argument takes the
tool to follow the legs in order), but when a program's estimate under a jerk limit J
exceeds a planner's cycle time without one, no planner with that J matches that planner on
that program: the corners alone cost more.
"""

import math

_EXIT = {}


def confined_exit(P, a, J):
    """Largest speed a 1-D motion confined to a band of half-width P (|q''| <= a,
    |q'''| <= J; J = inf for none) can leave it with, mm/s."""
    if P <= 0:
        return 0.0
    if not math.isfinite(J):
        return math.sqrt(4.0 * a * P)  # down at -a from the top, up at +a from the bottom
    key = (round(P, 9), a, J)
    if key in _EXIT:
        return _EXIT[key]
    # jerk -J for t1 from rest at +P (acceleration clamped to -a), then +J (clamped to +a)
    # until it crosses +P upwards; best over t1, the motion staying above -P
    tau = (P / J) ** (1.0 / 3.0)  # the band's time scale
    dt = tau / 2000.0
    best = 0.0
    for i in range(1, 400):
        t1 = i * tau / 50.0
        q, v, acc, t = P, 0.0, 0.0, 0.0
        while t < t1:
            acc = max(-a, acc - J * dt)
            v += acc * dt
            q += v * dt
            t += dt
        if q < -P:
            break
        ok = False
        for _ in range(200000):
            acc = min(a, acc + J * dt)
            v += acc * dt
            q += v * dt
            if q < -P:
                break
            if q >= P and v > 0:
                ok = True
                break
        if ok:
            best = max(best, v)
    _EXIT[key] = best
    return best


def ramp(v0, v1, a, J):
    """Time and distance from speed v0 to v1 > v0 (mm/s), starting at acceleration a and
    ending at 0 (jerk J; J = inf: constant a)."""
    dv = v1 - v0
    if dv <= 0:
        return 0.0, 0.0
    if not math.isfinite(J):
        T = dv / a
        return T, 0.5 * (v0 + v1) * T
    if dv >= a * a / (2 * J):
        t1 = (dv - a * a / (2 * J)) / a
        d1 = v0 * t1 + 0.5 * a * t1 * t1
        vm = v0 + a * t1
        tau = a / J
        return t1 + tau, d1 + vm * tau + 0.5 * a * tau * tau - J * tau ** 3 / 6.0
    a0 = math.sqrt(2 * J * dv)
    tau = a0 / J
    return tau, v0 * tau + 0.5 * a0 * tau * tau - J * tau ** 3 / 6.0


def leg_time(D, vin, vout, vcap, a, J):
    """Least time for a 1-D move over D from vin to vout, speed <= vcap."""
    if D <= 0:
        return 0.0
    vin, vout = min(vin, vcap), min(vout, vcap)

    def need(vc):
        tu, du = ramp(vin, vc, a, J)
        td, dd = ramp(vout, vc, a, J)
        return tu + td, du + dd

    T, d = need(vcap)
    if d <= D:
        return T + (D - d) / vcap
    lo, hi = max(vin, vout), vcap
    if need(lo)[1] > D:
        return D / lo if lo > 0 else 0.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if need(mid)[1] <= D:
            lo = mid
        else:
            hi = mid
    T, d = need(lo)
    return T + (D - d) / max(lo, 1e-9)


def estimate(prims, vmax, amax, jerk):
    """The leg estimate (s) of a program's primitives (compare.Line / compare.Arc, mm) and
    the number of legs it counted."""
    # straight runs: consecutive collinear lines of one kind and feed
    runs = []
    for pr in prims:
        if pr.length <= 0:
            continue
        if not hasattr(pr, "d"):
            runs.append(None)  # an arc: breaks the chain, takes no time here
            continue
        u = [c / pr.length for c in pr.d]
        if runs and runs[-1] is not None:
            last = runs[-1]
            if (last["rapid"] == pr.rapid and last["feed"] == pr.feed
                    and sum(x * y for x, y in zip(last["u"], u)) > 1 - 1e-9):
                last["len"] += pr.length
                continue
        runs.append({"u": u, "len": pr.length, "rapid": pr.rapid, "feed": pr.feed,
                     "tol": pr.tol})

    def corner(i, j):
        """Speed bound along run j's direction where it meets run i (None: no corner)."""
        if i < 0 or i >= len(runs):
            return 0.0  # the program starts and ends at rest
        a_, b_ = runs[i], runs[j]
        if a_ is None or b_ is None:
            return None
        if sum(x * y for x, y in zip(a_["u"], b_["u"])) > 0:
            return None
        tol = runs[max(i, j)]["tol"]  # the tolerance in force at that vertex
        n1 = sum(abs(c) for c in b_["u"])
        return confined_exit(tol, amax * n1, jerk * n1)

    total, legs = 0.0, 0
    for k, r in enumerate(runs):
        if r is None:
            continue
        vin, vout = corner(k - 1, k), corner(k + 1, k)
        if vin is None or vout is None:
            continue
        n1 = sum(abs(c) for c in r["u"])
        f = vmax if r["rapid"] else r["feed"] / 60.0
        vcap = min(f, vmax if r["rapid"] else f, vmax * n1)
        D = r["len"] - 2 * r["tol"]
        total += leg_time(D, vin, vout, vcap, amax * n1, jerk * n1)
        legs += 1
    return total, legs
