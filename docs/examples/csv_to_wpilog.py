"""Writes a CSV log's columns as a WPILib data log (.wpilog), one `double`
entry per column, every row's values at its time stamp (whole
microseconds), by the published layout (WPILib Data Log File Format
Specification 1.0). For the figures of docs/reference.md ("Input files"):

    python3 docs/examples/csv_to_wpilog.py IN.csv TIME_COLUMN OUT.wpilog [COLUMN ...]
"""
import csv
import struct
import sys


def record(entry, t_us, payload):
    # Header byte: entry id and payload size in 4 bytes, time stamp in 8 (each length - 1: 3, 3, 7).
    return struct.pack("<BIIQ", 3 | (3 << 2) | (7 << 4), entry, len(payload), t_us) + payload


def text(s):
    b = s.encode()
    return struct.pack("<I", len(b)) + b


def main(src, time_column, out, *columns):
    with open(src, newline="") as f:
        rows = list(csv.DictReader(f))
    columns = columns or [c for c in rows[0] if c != time_column]
    data = bytearray(b"WPILOG" + struct.pack("<H", 0x0100) + text("csv_to_wpilog " + src))
    for i, c in enumerate(columns, 1):
        data += record(0, 0, b"\x00" + struct.pack("<I", i) + text(c) + text("double") + text(""))
    for r in rows:
        t_us = round(float(r[time_column]) * 1e6)
        for i, c in enumerate(columns, 1):
            data += record(i, t_us, struct.pack("<d", float(r[c])))
    with open(out, "wb") as f:
        f.write(data)


if __name__ == "__main__":
    main(*sys.argv[1:])
