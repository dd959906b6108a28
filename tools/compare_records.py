#!/usr/bin/env python3
"""Compares two runs' records (JSON Lines, or folders of them, paired by file name),
ignoring what may differ between two correct runs: the timings and, with --ignore, other
top-level fields (for example `cameras` when one side predates it).

    python3 tools/compare_records.py A.jsonl B.jsonl [--ignore cameras]
    python3 tools/compare_records.py A_DIR B_DIR [--ignore cameras]

Exits 1 and names the first differing frame and field when they differ.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def records(path: Path, ignore: set) -> list:
    out = []
    for line in path.read_text().splitlines():
        if line.strip():
            r = json.loads(line)
            for k in ignore | {"timings_ms"}:
                r.pop(k, None)
            out.append(r)
    return out


def compare(a: Path, b: Path, ignore: set) -> bool:
    ra, rb = records(a, ignore), records(b, ignore)
    if len(ra) != len(rb):
        print(f"{a.name}: {len(ra)} against {len(rb)} records")
        return False
    for x, y in zip(ra, rb):
        if x != y:
            keys = sorted(k for k in set(x) | set(y) if x.get(k) != y.get(k))
            print(f"{a.name}: frame {x.get('frame')} differs in {keys}")
            return False
    return True


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("a", type=Path)
    ap.add_argument("b", type=Path)
    ap.add_argument("--ignore", action="append", default=[])
    args = ap.parse_args()
    ignore = set(args.ignore)
    if args.a.is_dir():
        pairs = [(f, args.b / f.name) for f in sorted(args.a.glob("*.jsonl"))]
    else:
        pairs = [(args.a, args.b)]
    same = 0
    for a, b in pairs:
        if not b.is_file():
            print(f"{b}: missing")
            continue
        same += compare(a, b, ignore)
    print(f"{same} of {len(pairs)} identical")
    sys.exit(0 if same == len(pairs) else 1)


if __name__ == "__main__":
    main()
