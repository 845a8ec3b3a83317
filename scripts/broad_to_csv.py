#!/usr/bin/env python3
"""Convert one BROAD trial (MATLAB v5 .mat, as published) to the CSV that
`replay` reads (../shared/data/broad/README.md).

Standard library only: the .mat reader below handles what the BROAD files
use (top-level real double matrices, optionally zlib-compressed elements),
and refuses anything else with an error instead of guessing.

Columns: t_s = i / sampling_rate (%.6f), imu_gyr (rad/s), imu_acc (m/s^2),
imu_mag (uT), opt_quat (w, x, y, z; sensor relative to ENU; NaN where the
optical system lost track), movement (0/1); floats as %.7g.

usage: broad_to_csv.py IN.mat OUT.csv   (OUT.csv must not exist or be IN)
"""
import math
import os
import struct
import sys
import zlib

MI_INT8, MI_UINT8, MI_INT16, MI_UINT16, MI_INT32, MI_UINT32 = 1, 2, 3, 4, 5, 6
MI_SINGLE, MI_DOUBLE, MI_INT64, MI_UINT64 = 7, 9, 12, 13
MI_MATRIX, MI_COMPRESSED = 14, 15
NUMERIC = {
    MI_INT8: "b", MI_UINT8: "B", MI_INT16: "h", MI_UINT16: "H", MI_INT32: "i",
    MI_UINT32: "I", MI_SINGLE: "f", MI_DOUBLE: "d", MI_INT64: "q", MI_UINT64: "Q",
}
HEADER = ("t_s,gyr_x_rad_s,gyr_y_rad_s,gyr_z_rad_s,acc_x_m_s2,acc_y_m_s2,acc_z_m_s2,"
          "mag_x_ut,mag_y_ut,mag_z_ut,ref_qw,ref_qx,ref_qy,ref_qz,moving")


class MatError(Exception):
    """The file is not a MAT v5 file this reader understands."""


def _elements(buf, endian):
    """Yields (type, payload) of the data elements in buf."""
    pos = 0
    while pos + 8 <= len(buf):
        typ, size = struct.unpack_from(endian + "II", buf, pos)
        if typ >> 16:  # small data element: size in the upper half, data in the tag
            size, typ = typ >> 16, typ & 0xFFFF
            yield typ, buf[pos + 4:pos + 4 + size]
            pos += 8
            continue
        start = pos + 8
        if start + size > len(buf):
            raise MatError("element runs past the end of the file (truncated download?)")
        yield typ, buf[start:start + size]
        pos = start + size
        if typ != MI_COMPRESSED:
            pos += (-size) % 8


def _numbers(typ, payload, endian):
    code = NUMERIC.get(typ)
    if code is None:
        raise MatError(f"unsupported numeric type {typ}")
    n = len(payload) // struct.calcsize(code)
    return list(struct.unpack_from(f"{endian}{n}{code}", payload))


def _matrix(payload, endian):
    """(name, rows, cols, column-major values) of a real numeric matrix."""
    parts = list(_elements(payload, endian))
    if len(parts) < 4:
        raise MatError("matrix element too short")
    flags = _numbers(parts[0][0], parts[0][1], endian)
    cls, complex_ = flags[0] & 0xFF, flags[0] & 0x800
    dims = _numbers(parts[1][0], parts[1][1], endian)
    name = parts[2][1].decode("ascii", "replace")
    if cls < 6 or cls > 15 or complex_ or len(dims) != 2:
        return name, None, None, None  # struct, cell, char, complex: not used here
    return name, dims[0], dims[1], [float(v) for v in _numbers(parts[3][0], parts[3][1], endian)]


def read_mat(path):
    """The file's real numeric variables: {name: list of rows}."""
    with open(path, "rb") as f:
        data = f.read()
    if len(data) < 128:
        raise MatError("shorter than a MAT header")
    endian = {b"IM": "<", b"MI": ">"}.get(data[126:128])
    if endian is None:
        raise MatError("not a MAT v5 file (no endian mark)")
    out = {}
    for typ, payload in _elements(data[128:], endian):
        if typ == MI_COMPRESSED:
            try:
                payload = zlib.decompress(payload)
            except zlib.error as e:
                raise MatError(f"compressed element: {e}") from e
            typ, payload = next(_elements(payload, endian))
        if typ != MI_MATRIX:
            continue
        name, rows, cols, values = _matrix(payload, endian)
        if values is not None:
            out[name] = [[values[c * rows + r] for c in range(cols)] for r in range(rows)]
    return out


def _need(mat, name, cols):
    if name not in mat:
        raise MatError(f"variable `{name}` missing")
    rows = mat[name]
    if any(len(r) != cols for r in rows):
        raise MatError(f"`{name}` is not N x {cols}")
    return rows


def convert(mat):
    """CSV lines (header first) of a trial."""
    rate = mat.get("sampling_rate", [[0.0]])[0][0]
    if not (math.isfinite(rate) and rate > 0):
        raise MatError("`sampling_rate` missing or not positive")
    gyr, acc, mag = (_need(mat, n, 3) for n in ("imu_gyr", "imu_acc", "imu_mag"))
    quat = _need(mat, "opt_quat", 4)
    moving = mat.get("movement")
    if moving is not None and len(moving) == 1 and len(moving[0]) == len(gyr):
        moving = [[v] for v in moving[0]]  # a row vector
    moving = moving if moving is not None else [[1.0]] * len(gyr)
    n = len(gyr)
    if not (len(acc) == len(mag) == len(quat) == len(moving) == n):
        raise MatError("the variables have different lengths")
    g7 = lambda v: "nan" if math.isnan(v) else "%.7g" % v
    lines = [HEADER]
    for i in range(n):
        vals = gyr[i] + acc[i] + mag[i] + quat[i]
        lines.append("%.6f," % (i / rate) + ",".join(g7(v) for v in vals) + ",%d" % int(moving[i][0] != 0))
    return lines


def main(argv):
    if len(argv) != 3:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    src, dst = argv[1], argv[2]
    if os.path.exists(dst) and os.path.samefile(src, dst):
        print(f"broad_to_csv: {dst} is the input", file=sys.stderr)
        return 2
    try:
        lines = convert(read_mat(src))
    except (MatError, OSError) as e:
        print(f"broad_to_csv: {src}: {e}", file=sys.stderr)
        return 1
    tmp = dst + ".part"
    with open(tmp, "w") as f:
        f.write("\n".join(lines) + "\n")
    os.replace(tmp, dst)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
