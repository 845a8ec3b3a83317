#!/usr/bin/env python3
"""Tests of broad_to_csv.py on small synthetic MAT v5 files written here
(the real dataset cannot be downloaded on the build machines).
Run: python3 scripts/test_broad_to_csv.py"""
import math
import os
import struct
import subprocess
import sys
import tempfile
import unittest
import zlib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import broad_to_csv as b  # noqa: E402


def _element(typ, payload):
    pad = (-len(payload)) % 8
    return struct.pack("<II", typ, len(payload)) + payload + b"\0" * pad


def _matrix(name, rows):
    r, c = len(rows), len(rows[0])
    values = [rows[i][j] for j in range(c) for i in range(r)]  # column-major
    body = (_element(b.MI_UINT32, struct.pack("<II", 6, 0))  # class double
            + _element(b.MI_INT32, struct.pack("<ii", r, c))
            + _element(b.MI_INT8, name.encode())
            + _element(b.MI_DOUBLE, struct.pack(f"<{len(values)}d", *values)))
    return _element(b.MI_MATRIX, body)


def write_mat(path, variables, compress):
    header = b"MATLAB 5.0 MAT-file, synthetic test".ljust(116) + b"\0" * 8 + struct.pack("<H", 0x0100) + b"IM"
    out = header
    for name, rows in variables.items():
        m = _matrix(name, rows)
        if compress:
            z = zlib.compress(m)
            m = struct.pack("<II", b.MI_COMPRESSED, len(z)) + z
        out += m
    with open(path, "wb") as f:
        f.write(out)


def trial(n):
    nan = float("nan")
    return {
        "sampling_rate": [[2000.0 / 7.0]],
        "imu_gyr": [[0.001 * i, -0.0042, 0.0] for i in range(n)],
        "imu_acc": [[-0.2361874, -0.3631649, 9.919315]] * n,
        "imu_mag": [[0.2226069, 15.82182, -38.33789]] * n,
        "opt_quat": [[nan] * 4 if i == 1 else [0.9997327, -0.01964271, 0.01212263, -0.001288933] for i in range(n)],
        "movement": [[float(i >= 2)] for i in range(n)],
    }


class Convert(unittest.TestCase):
    def test_both_encodings_give_the_readme_format(self):
        for compress in (False, True):
            with tempfile.TemporaryDirectory() as d:
                src, dst = os.path.join(d, "t.mat"), os.path.join(d, "t.csv")
                write_mat(src, trial(4), compress)
                self.assertEqual(b.main(["x", src, dst]), 0)
                lines = open(dst).read().splitlines()
                self.assertEqual(lines[0], b.HEADER)
                self.assertEqual(
                    lines[1],
                    "0.000000,0,-0.0042,0,-0.2361874,-0.3631649,9.919315,0.2226069,15.82182,-38.33789,"
                    "0.9997327,-0.01964271,0.01212263,-0.001288933,0")
                self.assertTrue(lines[2].startswith("0.003500,0.001,"))
                self.assertIn(",nan,nan,nan,nan,0", lines[2])
                self.assertTrue(lines[4].endswith(",1"))

    def test_bad_files_are_errors(self):
        with tempfile.TemporaryDirectory() as d:
            src, dst = os.path.join(d, "t.mat"), os.path.join(d, "t.csv")
            with open(src, "wb") as f:
                f.write(b"not a mat file")
            self.assertEqual(b.main(["x", src, dst]), 1)
            self.assertFalse(os.path.exists(dst))
            t = trial(3)
            del t["imu_mag"]
            write_mat(src, t, True)
            self.assertEqual(b.main(["x", src, dst]), 1)
            write_mat(src, trial(3), False)
            data = open(src, "rb").read()
            with open(src, "wb") as f:
                f.write(data[:-20])  # a cut download
            self.assertEqual(b.main(["x", src, dst]), 1)
            self.assertEqual(b.main(["x", src, src]), 2)

    def test_replay_reads_the_output(self):
        replay = os.environ.get("REPLAY_BIN")
        if not replay:
            print("skipped: REPLAY_BIN not set", file=sys.stderr)
            return
        with tempfile.TemporaryDirectory() as d:
            src, dst = os.path.join(d, "t.mat"), os.path.join(d, "t.csv")
            write_mat(src, trial(400), True)
            self.assertEqual(b.main(["x", src, dst]), 0)
            r = subprocess.run([replay, dst], capture_output=True, text=True)
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertIn("MEAN over 1 file(s)", r.stdout)


if __name__ == "__main__":
    unittest.main()
