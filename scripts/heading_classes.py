#!/usr/bin/env python3
"""The simulated heading classes, scored as replay scores BROAD: one command.

For each class and seed: `cargo sim --trajectory T --seed N --duration D [--fault ...]
[--gyro-scale S] --csv OUT/<class>_<seed>.csv` (the whole simulated stack: register-level
chips with the board's datasheet-size errors drawn from the seed, the boot calibrations,
the firmware's pipeline), then `cargo replay OUT/<class>_<seed>.csv --sensor mpu9250
--filter K` for K in fixed, f32, vqf (total / heading / inclination RMS over moving rows,
BROAD's metric). For the fast-rotation classes also the heading error at the end of each
rest (from `replay --out`). Prints one table: per class, the mean over seeds and the
per-seed totals.

Classes (fault TIME is seconds of flight; the filter's start-up ends at 3 s):
  handheld-slow, handheld            no magnet (the board's own errors only)
  handheld-slow+disc60, handheld+disc60
                                     a 3 x 1 mm NdFeB disc (Br 1.2 T: m = Br*V/mu0 =
                                     6.8e-3 A*m^2) riding 60 mm from the sensor from 9 s:
                                     |d| = 0.1*m/r^3 = 3.1 uT
  handheld+disc30                    a 2 x 0.5 mm disc (1.5e-3 A*m^2) at 30 mm: 5.6 uT
  fastaxes                           two turns at 300-500 deg/s about six axes, 3 s rests;
                                     the board's drawn gyro scale (within +-2 %)
  fastaxes+3%, fastaxes-3%, fastaxes+7%
                                     the gyro's sensitivity error set on every axis
                                     (datasheet +-3 % at 25 degC; +7 %: +4 % more over
                                     temperature)

Usage: scripts/heading_classes.py [--seeds 1,2,3,4] [--duration 120] [--out DIR]
                                  [--classes a,b,...]
Exit status 0 done, 1 a run failed, 2 bad arguments.
"""
import argparse
import csv
import math
import os
import subprocess
import sys
import tempfile

DISC60 = "8:dipole-ride:60:6800"
DISC30 = "8:dipole-ride:30:1500"
CLASSES = {
    "handheld-slow": ("handheld-slow", []),
    "handheld-slow+disc60": ("handheld-slow", ["--fault", DISC60]),
    "handheld": ("handheld", []),
    "handheld+disc60": ("handheld", ["--fault", DISC60]),
    "handheld+disc30": ("handheld", ["--fault", DISC30]),
    "fastaxes": ("fastaxes", []),
    "fastaxes+3%": ("fastaxes", ["--gyro-scale", "0.03"]),
    "fastaxes-3%": ("fastaxes", ["--gyro-scale", "-0.03"]),
    "fastaxes+7%": ("fastaxes", ["--gyro-scale", "0.07"]),
}
FILTERS = ("fixed", "f32", "vqf")


def args():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--seeds", default="1,2,3,4", help="comma-separated seeds (default 1,2,3,4)")
    p.add_argument("--duration", type=float, default=120.0, help="flight seconds, in [10, 3600]")
    p.add_argument("--out", help="folder for the CSVs (created; default: a temporary one)")
    p.add_argument("--classes", default=",".join(CLASSES), help="comma-separated subset")
    a = p.parse_args()
    try:
        a.seeds = [int(s) for s in a.seeds.split(",")]
    except ValueError:
        p.error("--seeds: comma-separated integers")
    if not a.seeds or any(s < 0 for s in a.seeds):
        p.error("--seeds: at least one seed, each >= 0")
    if not 10.0 <= a.duration <= 3600.0:
        p.error("--duration must be within [10, 3600] s")
    a.classes = a.classes.split(",")
    unknown = [c for c in a.classes if c not in CLASSES]
    if unknown:
        p.error("unknown class(es) %s; known: %s" % (", ".join(unknown), ", ".join(CLASSES)))
    return a


def binaries():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    subprocess.run(["cargo", "build", "-q", "--release", "-p", "sim", "-p", "replay"],
                   cwd=root, check=True)
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(root, "target"))
    return [os.path.join(target, "release", b) for b in ("sim", "replay")]


def replay(bin_replay, path, kind, out=None):
    cmd = [bin_replay, path, "--sensor", "mpu9250", "--filter", kind]
    if out:
        cmd += ["--out", out]
    text = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    for line in text.splitlines():
        if line.startswith(path):
            return [float(x) for x in line.split()[-3:]]
    raise RuntimeError("replay printed no score for %s" % path)


def heading_err_deg(q, r):
    # e = q (x) conj(r); heading = 2 atan(|e_z / e_w|), as replay scores it.
    qw, qx, qy, qz = q
    rw, rx, ry, rz = r[0], -r[1], -r[2], -r[3]
    ew = qw * rw - qx * rx - qy * ry - qz * rz
    ez = qw * rz + qx * ry - qy * rx + qz * rw
    return math.degrees(2 * math.atan2(abs(ez), abs(ew)))


def after_rests(rec, est):
    """Heading error (deg) at the last row of each still phase longer than 2 s (after the start)."""
    with open(rec) as f:
        rows = list(csv.DictReader(f))
    with open(est) as f:
        q = [[float(x) for x in r[1:5]] for r in csv.reader(f) if r and r[0] != "t_s"]
    out, start = [], None
    for i, r in enumerate(rows):
        still = r["moving"] == "0"
        if still and start is None:
            start = i
        if not still and start is not None:
            t0, t1 = float(rows[start]["t_s"]), float(rows[i - 1]["t_s"])
            if t1 - t0 > 2.0 and t0 > 5.0:
                ref = [float(rows[i - 1][k]) for k in ("ref_qw", "ref_qx", "ref_qy", "ref_qz")]
                out.append(heading_err_deg(q[i - 1], ref))
            start = None
    return out


def main():
    a = args()
    out = a.out or tempfile.mkdtemp(prefix="heading_classes_")
    os.makedirs(out, exist_ok=True)
    bin_sim, bin_replay = binaries()
    print("class                   filter  total / heading / incl (mean over seeds %s)  per-seed total"
          % ",".join(map(str, a.seeds)))
    for name in a.classes:
        trajectory, extra = CLASSES[name]
        scores = {k: [] for k in FILTERS}
        rests = []
        for seed in a.seeds:
            path = os.path.join(out, "%s_%d.csv" % (name.replace("%", "pc"), seed))
            cmd = [bin_sim, "--trajectory", trajectory, "--seed", str(seed), "--duration",
                   str(a.duration), "-q", "--print-every", "0", "--csv", path] + extra
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
            for k in FILTERS:
                est = path[:-4] + "_est.csv" if (k == "fixed" and "fast" in name) else None
                scores[k].append(replay(bin_replay, path, k, est))
                if est:
                    rests.append(after_rests(path, est))
        for k in FILTERS:
            s = scores[k]
            mean = [sum(x[i] for x in s) / len(s) for i in range(3)]
            print("%-23s %-6s  %5.2f / %5.2f / %5.2f                      %s"
                  % (name, k, *mean, " ".join("%.2f" % x[0] for x in s)))
        for seed, r in zip(a.seeds, rests):
            print("%-23s fixed   seed %d: heading error after each rest %s deg"
                  % (name, seed, " ".join("%.1f" % x for x in r)))
    print("CSVs in %s (cargo replay FILE --sensor mpu9250 --filter fixed|f32|vqf)" % out)


if __name__ == "__main__":
    try:
        main()
    except (subprocess.CalledProcessError, RuntimeError, OSError) as e:
        print("heading_classes: %s" % e, file=sys.stderr)
        sys.exit(1)
