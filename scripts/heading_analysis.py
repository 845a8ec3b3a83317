#!/usr/bin/env python3
"""The figures of fc-ahrs's README section "Heading: body-fixed disturbances and fast turns".

1. Fields of body-fixed sources: a dipole, 0.1*m/r^3 uT equatorial (twice on the axis),
   m in A*m^2 and r in m; a wire, mu0*I/(2*pi*d); a wire pair s apart, mu0*I*s/(2*pi*d^2).
2. A body-fixed offset d over attitudes spread uniformly: the largest norm and dip change,
   the share the 10 %/10 deg check rejects, and the compass error of the fields it accepts.
3. A one-dimensional model of the full filter's heading loop through fast turns with rests:
   e' = s*w - tol*|wbar|*sat(tan(e)/zone) - sat(tan(e))/tau_h, wbar' = (w - wbar)/tau_w.
4. Fast turns about tilted axes (the simulator's `fastaxes`): the loss s*A splits into
   heading (the axis's vertical part) and tilt (its horizontal part); the accelerometer's
   correction (natural frequency 1/tau_tilt, damping 3/4) leaves
   e^(-3T/(4tau))(cos(wd T) + (3/4)/(wd tau) sin(wd T)), wd = sqrt(7)/(4 tau), of a tilt
   error after T, and at rest (once the gyro bias estimator's rest test holds) the same
   loop at tau = 0.25 s; a tilt error d about the field's horizontal direction turns the
   field seen in the estimate's frame by atan(tan(dip)*sin d) in heading while its dip
   moves only in second order, so the norm/dip check cannot see it.
5. The simulator's dipole classes (`dipole-ride:MM:UAM2`): |d|, eps, the largest norm and
   dip change and the largest compass error, asin(|d|/B_h).
No arguments; pure Python (no numpy); deterministic.
"""
import math
import random

MU0_4PI = 1e-7




# fc-ahrs Config::rest_tilt_tau_s (s).
REST_TILT_TAU = 0.25
def tilt_left(t, tau):
    """The share of a tilt error the accelerometer's correction leaves after t: the
    step response's remainder of e'' + (3/2)e'/tau + e/tau^2 (natural frequency 1/tau,
    damping 3/4; fc-ahrs README, "The full filter", step 4)."""
    zeta = 0.75
    sigma, wd = zeta / tau, math.sqrt(1.0 - zeta * zeta) / tau
    return math.exp(-sigma * t) * (math.cos(wd * t) + sigma / wd * math.sin(wd * t))

def dipole_ut(m_am2, r_m, axial):
    return MU0_4PI * m_am2 / r_m ** 3 * (2 if axial else 1) * 1e6


def sources():
    v = math.pi * 1.5e-3 ** 2 * 1e-3
    m_disc = 1.2 / (4 * math.pi * 1e-7) * v
    print("1. sources (uT, equatorial / axial)")
    for name, m in (("NdFeB disc 3x1 mm, m=%.2e" % m_disc, m_disc),
                    ("m=1e-3 A m2", 1e-3), ("m=1e-4 A m2", 1e-4)):
        row = ["%5.2f / %5.2f" % (dipole_ut(m, r, False), dipole_ut(m, r, True))
               for r in (0.03, 0.045, 0.06)]
        print("  %-28s 3 cm %s  4.5 cm %s  6 cm %s" % (name, *row))
    for i in (10, 30):
        for d in (0.03, 0.06):
            print("  I=%2d A at %.0f cm: one lead %.1f uT, pair 4 mm apart %.2f uT"
                  % (i, d * 100, 2e-7 * i / d * 1e6, 2e-7 * i * 0.004 / d ** 2 * 1e6))


def unit(rng):
    while True:
        v = [rng.gauss(0, 1) for _ in range(3)]
        n = math.sqrt(sum(x * x for x in v))
        if n > 1e-9:
            return [x / n for x in v]


def offsets():
    rng = random.Random(1)
    dirs = [unit(rng) for _ in range(40000)]
    for total, dip in ((50.0, 60.0), (49.8, 67.0)):
        b = [total * math.cos(math.radians(dip)), 0.0, total * math.sin(math.radians(dip))]
        print("2. field %.1f uT, dip %.0f deg, horizontal %.1f uT" % (total, dip, b[0]))
        for d in (2, 3, 5, 7.5, 10, 15):
            rej, se, emax, n_acc, dn_max, dd_max = 0, 0.0, 0.0, 0, 0.0, 0.0
            for u in dirs:
                h = [b[i] + d * u[i] for i in range(3)]
                n = math.sqrt(sum(x * x for x in h))
                dn = n / total - 1
                dd = math.degrees(math.asin(h[2] / n)) - dip
                dn_max, dd_max = max(dn_max, abs(dn)), max(dd_max, abs(dd))
                if abs(dn) > 0.1 or abs(dd) > 10:
                    rej += 1
                    continue
                e = math.degrees(math.atan2(h[1], h[0]))
                se, emax, n_acc = se + e * e, max(emax, abs(e)), n_acc + 1
            rms = math.sqrt(se / n_acc) if n_acc else float("nan")
            print("  |d| %4.1f uT eps %.2f: max norm %4.1f %%, dip %5.2f deg; rejected %5.1f %%;"
                  " accepted compass error RMS %5.2f max %5.2f deg; asin(|d|/Bh) %5.2f deg"
                  % (d, d / total, 100 * dn_max, dd_max, 100 * rej / len(dirs), rms, emax,
                     math.degrees(math.asin(min(1.0, d / b[0])))))


def heading_loop(s, tol, tau_h, rate_dps=400.0, turn_s=2.25, rest_s=8.0, cycles=2,
                 tau_w=2.0, zone=0.05, dt=1e-3):
    e, wbar, out = 0.0, 0.0, []
    for _ in range(cycles):
        for w_dps, dur in ((rate_dps, turn_s), (0.0, rest_s)):
            w = math.radians(w_dps)
            for _ in range(int(dur / dt)):
                wbar += (w - wbar) * dt / tau_w
                t = math.tan(e)
                corr = tol * abs(wbar) * max(-1.0, min(1.0, t / zone)) + max(-1.0, min(1.0, t)) / tau_h
                e += (s * w - corr) * dt
            out.append(math.degrees(e))
    return out


def fast_turns():
    print("3. heading error (deg) after turn 1, rest 1, turn 2, rest 2 (2.5 turns at 400 deg/s, 8 s rests)")
    for tol, tau_h in ((0.03, 40.0), (0.01, 80.0), (0.0, 40.0)):
        for s in (0.01, 0.03, 0.07, -0.03):
            print("  tol %.2f tau_h %2.0f s, scale error %+.2f: %s"
                  % (tol, tau_h, s, ", ".join("%.1f" % x for x in heading_loop(s, tol, tau_h))))
    print("  loss per turn without correction: 1 %% %.1f, 3 %% %.1f, 7 %% %.1f deg" % (3.6, 10.8, 25.2))


def unit3(v):
    n = math.sqrt(sum(x * x for x in v))
    return [x / n for x in v]


def tilted_axes(tau_tilt=3.0, dip=60.0, a_deg=720.0):
    axes = ((0, 0, 1), (1, 0, 0), (0, -1, 0), (1, 0, -1), (0, 1, 1), (-1, 1, -1))
    print("4. fast turns about tilted axes: two turns (720 deg), tilt tau %.0f s, dip %.0f deg"
          % (tau_tilt, dip))
    for s in (0.02, 0.03, 0.07):
        row = []
        for ax in axes:
            u = unit3(ax)
            h = math.sqrt(u[0] ** 2 + u[1] ** 2)
            row.append("(%+.0f,%+.0f,%+.0f) %5.1f / %5.1f" % (*ax, s * a_deg * abs(u[2]), s * a_deg * h))
        print("  s %.2f: heading / tilt loss (deg) per axis: %s" % (s, "; ".join(row)))
    for t in (1.0, 3.0, 4.0, 6.0, 10.0):
        print("  tilt left after %4.1f s: %3.0f %%" % (t, 100 * tilt_left(t, tau_tilt)))
    # At rest (the bias estimator's test, 1.5 s) the stages run at REST_TILT_TAU.
    for t in (0.5, 1.0, 1.5):
        print("  at rest, %.1f s after the rest test (tau %.2f s): %5.1f %% left"
              % (t, REST_TILT_TAU, 100 * abs(tilt_left(t, REST_TILT_TAU))))
    td = math.tan(math.radians(dip))
    for d in (1, 2, 5, 10, 15, 20):
        r = math.radians(d)
        bn, bv = math.cos(math.radians(dip)), math.sin(math.radians(dip))
        # The field (bn, 0, bv) turned by d about north: (bn, -bv sin d, bv cos d).
        dip_seen = math.degrees(math.atan2(bv * math.cos(r), math.hypot(bn, bv * math.sin(r))))
        print("  tilt error %2d deg about north: compass error %5.1f deg, dip change %4.2f deg;"
              " about east: compass 0, dip change %2d deg"
              % (d, math.degrees(math.atan(td * math.sin(r))), dip - dip_seen, d))


def dipole_classes(total=50.0, dip=60.0):
    bh = total * math.cos(math.radians(dip))
    print("5. dipole-ride classes (field %.0f uT, dip %.0f deg, B_h %.1f uT)" % (total, dip, bh))
    for mm, uam2, what in ((60, 6800, "NdFeB disc 3x1 mm"), (30, 1500, "NdFeB disc 2x0.5 mm"),
                           (45, 6800, "NdFeB disc 3x1 mm")):
        d = 0.1 * uam2 * 1e-6 / (mm * 1e-3) ** 3
        eps = d / total
        print("  %-20s m %.1e A*m2 at %2d mm: |d| %.2f uT, eps %.3f: norm +-%.1f %%, dip +-%.1f deg"
              " (check: 10 %%, 10 deg); compass error up to %.1f deg"
              % (what, uam2 * 1e-6, mm, d, eps, 100 * eps, math.degrees(math.asin(min(1, eps))),
                 math.degrees(math.asin(min(1.0, d / bh)))))


if __name__ == "__main__":
    sources()
    offsets()
    fast_turns()
    tilted_axes()
    dipole_classes()
