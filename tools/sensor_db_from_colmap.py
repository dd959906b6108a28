#!/usr/bin/env python3
"""Writes crates/monohand-vision/data/sensor_widths.csv from COLMAP's camera database
(src/colmap/sensor/specs.cc, BSD-3-Clause), keeping its licence notice and the commit.

    python3 tools/sensor_db_from_colmap.py COLMAP_GIT_DIR [COMMIT] > crates/monohand-vision/data/sensor_widths.csv

Each `specs["make"]` block with `make_specs.emplace_back("model", width)` lines becomes
`make;model;width_mm` rows (semicolons: some models have commas, `iphone3,1`); the names stay as COLMAP cleans them (lower case, no spaces or
dashes), which is how monohand looks them up too.
"""

import re
import subprocess
import sys


def main() -> None:
    git, commit = sys.argv[1], (sys.argv[2] if len(sys.argv) > 2 else "HEAD")
    commit = subprocess.run(["git", "-C", git, "rev-parse", commit], check=True,
                            capture_output=True, text=True).stdout.strip()
    show = lambda p: subprocess.run(["git", "-C", git, "show", f"{commit}:{p}"], check=True,
                                    capture_output=True, text=True).stdout
    specs = show("src/colmap/sensor/specs.cc")
    licence = show("COPYING.txt")
    print("# Sensor widths (the longer side of the sensor, mm) by EXIF Make and Model.")
    print("# Source: COLMAP, src/colmap/sensor/specs.cc at commit " + commit)
    print("# (https://github.com/colmap/colmap), converted by tools/sensor_db_from_colmap.py.")
    print("# Fields are separated by semicolons (some model names have commas).")
    print("# Names are cleaned as COLMAP cleans them: lower case, no spaces, no dashes.")
    print("# COLMAP's licence (BSD-3-Clause), kept as it requires:")
    for line in licence.splitlines():
        print(("# " + line).rstrip())
    print("make;model;sensor_width_mm")
    make = None
    rows = 0
    for line in specs.splitlines():
        m = re.search(r'specs\["([^"]+)"\]', line)
        if m:
            make = m.group(1)
            continue
        m = re.search(r'emplace_back\("([^"]+)",\s*([0-9.]+)f?\)', line)
        if m and make is not None:
            model, width = m.group(1), float(m.group(2))
            if ";" in model or ";" in make:
                raise SystemExit(f"a semicolon in {make} {model}")
            print(f"{make};{model};{width:g}")
            rows += 1
    print(f"{rows} rows", file=sys.stderr)


if __name__ == "__main__":
    main()
