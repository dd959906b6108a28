#!/usr/bin/env bash
# Every test of the project: the Rust workspace, then the Python package (built as a wheel
# with maturin into a fresh venv, and tested with pytest against the command-line tool).
# Data tests read ../shared beside the repository; missing data or models fail, never skip.
# The system tools the tests run are installed first when missing (apt-get, as root or
# with sudo; scripts/prerequisites.sh says which).
set -euo pipefail
cd "$(dirname "$0")/.."

# The Rust tests in release, like the CLI and the wheel below: the dependencies are
# compiled once for all three (one profile, scripts/test-release.toml, and one set of
# features, crates/monohand-workspace-hack). The CLI's `rerun` feature (`run --rerun`,
# off in a plain build: docs/visualisation.md) is on here, as in the wheel.
rust_tests=(cargo test --workspace --release --config scripts/test-release.toml --features monohand-cli/rerun)
# The CLI the Python tests run (release: the dependencies are those the tests built, tract
# is not compiled again), with Rerun recordings.
cli_build=(cargo build --release -p monohand-cli --features rerun)

# TEST_BUILD_ONLY=1: compile the Rust tests and the CLI, run nothing (.ci/run does that in
# the background while it lints, then runs this script whole, which finds them built). A
# build needs none of the system tools, so it installs nothing: no apt-get of its own, in
# the background beside .ci/run's (which installs them before it starts its builds).
if [ "${TEST_BUILD_ONLY:-0}" = 1 ]; then
  "${rust_tests[@]}" --no-run
  "${cli_build[@]}"
  exit 0
fi

# The system tools the tests run (ffmpeg and ffprobe, chromium, Xvfb, xwd, xdotool, npm,
# exiftool): whichever are missing are installed with apt-get, as root or through sudo,
# and named first (scripts/prerequisites.sh; without root or sudo it names them and stops).
scripts/prerequisites.sh

echo "== the tools' tests (tools/test_*.py, Python's unittest: the prerequisites script above, the import loop checker)"
python3 -m unittest discover -s tools -p 'test_*.py' -v

echo "== Rust tests"
"${rust_tests[@]}"

echo "== Python package"
"${cli_build[@]}"
venv="target/pyvenv"
rm -rf "$venv" target/wheels-test
python3 -m venv "$venv"
"$venv/bin/pip" install -q --disable-pip-version-check -r crates/monohand-py/requirements-test.txt
"$venv/bin/maturin" build --release -q -i "$venv/bin/python" \
  -m crates/monohand-py/Cargo.toml -o target/wheels-test
"$venv/bin/pip" install -q --disable-pip-version-check --no-deps target/wheels-test/monohand-*.whl
(cd crates/monohand-py/tests && MONOHAND_BIN="$PWD/../../../target/release/monohand" \
  "../../../$venv/bin/python" -m pytest -q -p no:cacheprovider)
