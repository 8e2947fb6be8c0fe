#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Reads an imucal calibration record (format version 1, docs/record_format.md) with the Python
standard library alone: what a test bench or a production line needs to check what a device
stored.

    tools/read_record.py RECORD                 prints the record's parts and parameters
    tools/read_record.py RECORD --check JSON    exits 1 unless the JSON `imucal calibrate --json`
                                                wrote names the parameters as this reader does
                                                and every accelerometer and gyroscope parameter
                                                equals the JSON's (to float precision)
"""
import json
import struct
import sys
import zlib

# The library's kAccelParamNames and kGyroParamNames (imucal/models/accel_model.hpp,
# gyro_model.hpp), the keys of `imucal calibrate --json`; --check and the Python package's test
# hold them equal.
ACCEL_NAMES = ["alpha_yz", "alpha_zy", "alpha_zx", "s_x", "s_y", "s_z", "b_x", "b_y", "b_z"]
GYRO_NAMES = ["gamma_yz", "gamma_zy", "gamma_zx", "gamma_xz", "gamma_xy", "gamma_yx",
              "s_x", "s_y", "s_z", "b_x", "b_y", "b_z"]


def read_record(data):
    """The record in `data` (bytes after its own length are ignored, as in a flash slot)."""
    if len(data) < 24:
        raise ValueError("shorter than a record's header and CRC")
    magic, version, _, length = struct.unpack_from("<4sBBH", data, 0)
    if magic != b"IMCR":
        raise ValueError("no imucal record (magic is not IMCR)")
    if version != 1:
        raise ValueError("format version %d: this reader knows version 1" % version)
    if length < 24 or length > len(data):
        raise ValueError("length %d does not fit the %d bytes given" % (length, len(data)))
    (crc,) = struct.unpack_from("<I", data, length - 4)
    if zlib.crc32(data[:length - 4]) != crc:
        raise ValueError("CRC-32 mismatch: the record is corrupted")
    device_id, sensor_id, parts = struct.unpack_from("<IIH", data, 8)
    out = {"device_id": device_id, "sensor_id": sensor_id, "parts": parts, "unknown_tags": []}
    offset = 20
    while offset < length - 4:
        tag, _, size = struct.unpack_from("<BBH", data, offset)
        payload = data[offset + 4:offset + 4 + size]
        if offset + 4 + size > length - 4:
            raise ValueError("section at byte %d runs past the CRC" % offset)
        if tag == 1:  # info
            quality, flags, _, temperature, rate = struct.unpack_from("<BBHff", payload)
            out["quality"] = quality
            out["temperature_c"] = temperature if flags & 1 else None
            out["rate_hz"] = rate
        elif tag == 2:  # accelerometer
            poses, _ = struct.unpack_from("<HH", payload)
            v = struct.unpack_from("<19f", payload, 4)
            out["accelerometer"] = {"poses": poses, "params": dict(zip(ACCEL_NAMES, v[0:9])),
                                    "sigma": dict(zip(ACCEL_NAMES, v[9:18])),
                                    "residual_rms_mps2": v[18]}
        elif tag == 3:  # gyroscope
            moves, flags, _ = struct.unpack_from("<HBB", payload)
            v = struct.unpack_from("<25f", payload, 4)
            out["gyroscope"] = {"moves": moves, "bias_refined": bool(flags & 1),
                                "params": dict(zip(GYRO_NAMES, v[0:12])),
                                "sigma": dict(zip(GYRO_NAMES, v[12:24])),
                                "residual_rms_deg": v[24]}
        elif tag == 4:  # magnetometer
            samples, quality, flags = struct.unpack_from("<HBB", payload)
            v = struct.unpack_from("<26f", payload, 4)
            out["magnetometer"] = {"samples": samples, "quality": quality,
                                   "aligned": bool(flags & 1),
                                   "soft_iron": [list(v[0:3]), list(v[3:6]), list(v[6:9])],
                                   "hard_iron": list(v[9:12]), "hard_iron_sigma": list(v[12:15]),
                                   "soft_iron_sigma": list(v[15:21]), "field_ut": v[21],
                                   "fit_error_pct": v[22], "coverage": v[23], "dip_deg": v[24],
                                   "dip_sigma_deg": v[25]}
        elif tag == 5:  # temperature model
            order, flags, rests = struct.unpack_from("<BBH", payload)
            n = 3 * (order + 1)  # b0, b1 (b2) per sensor, 3 axes each
            v = struct.unpack_from("<%df" % (3 + 4 * n), payload, 4)
            t0, t_low, t_high = v[0:3]
            values = v[3:]

            def sensor(k):
                b = values[2 * n * k:2 * n * k + n]
                s = values[2 * n * k + n:2 * n * (k + 1)]
                return {"b": [list(b[3 * i:3 * i + 3]) for i in range(order + 1)],
                        "sigma": [list(s[3 * i:3 * i + 3]) for i in range(order + 1)]}

            out["temperature"] = {"order": order, "rests": rests, "t0_c": t0,
                                  "range_c": (t_low, t_high),
                                  "accel_usable": bool(flags & 1), "gyro_usable": bool(flags & 2),
                                  "accelerometer": sensor(0), "gyroscope": sensor(1)}
        else:  # a newer format's section: skipped, as the library does
            out["unknown_tags"].append(tag)
        offset += 4 + size
    return out


def check_against_json(record, summary):
    """The differences between the record's parameters and those of `imucal calibrate --json`."""
    problems = []
    for sensor, names in (("accelerometer", ACCEL_NAMES), ("gyroscope", GYRO_NAMES)):
        if sensor not in record:
            problems.append("%s: not in the record" % sensor)
            continue
        keys = list(summary[sensor]["parameters"])
        if keys != names:
            problems.append("%s: the JSON names the parameters %s, this reader %s"
                            % (sensor, ", ".join(keys), ", ".join(names)))
            continue
        for name, value in record[sensor]["params"].items():
            want = summary[sensor]["parameters"][name]["value"]
            if abs(value - want) > 1e-6 * max(abs(want), 1e-30):
                problems.append("%s %s: record %.9g, JSON %.9g" % (sensor, name, value, want))
    return problems


def main(argv):
    if len(argv) not in (2, 4) or (len(argv) == 4 and argv[2] != "--check"):
        sys.stderr.write(__doc__)
        return 2
    try:
        with open(argv[1], "rb") as f:
            record = read_record(f.read())
    except (OSError, ValueError, struct.error) as e:
        sys.stderr.write("read_record: %s: %s\n" % (argv[1], e))
        return 2
    if len(argv) == 4:
        with open(argv[3]) as f:
            problems = check_against_json(record, json.load(f))
        for p in problems:
            print(p)
        print("%s: %s" % (argv[1], "matches the JSON" if not problems else "DIFFERS"))
        return 1 if problems else 0
    print(json.dumps(record, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
