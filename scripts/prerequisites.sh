#!/usr/bin/env bash
# The system tools the tests need, installed with apt-get when missing (issue 66): the one
# list, used by scripts/test.sh (before it runs the tests) and by .ci/run (before its builds
# start, so that no two apt-gets ever run at once).
#   ffmpeg, ffprobe  ffmpeg                  video (docs/video.md) and the bars
#   chromium         chromium                the tests of what a person sees, in a headless browser
#   Xvfb             xvfb                    a virtual X server for the --show window,
#   xwd              x11-apps                  screenshotted with xwd
#   xdotool          xdotool                   and sent a key with xdotool
#   npm              npm                     three.js, the benchmark's packages, the glTF validator
#   exiftool         libimage-exiftool-perl  the independent reader of the video metadata tests
#                                            (crates/monohand-media/tests/quicktime.rs)
#   python3's venv   python3-venv            the wheel's fresh venv (Debian's python3 has venv
#                                            only with it: `python3 -c 'import ensurepip'`)
# Installs as root, or through sudo; says what it installs. Without root or sudo (or apt-get)
# it names the missing packages and exits 1, as it does when an install leaves one missing.
# `--check`: only says what is missing (exit 1 if anything is), installs nothing.
set -euo pipefail

check_only=0
case "${1:-}" in
  "") ;;
  --check) check_only=1 ;;
  *) echo "usage: $0 [--check]" >&2; exit 2 ;;
esac

# command package, one pair a line.
tools="ffmpeg ffmpeg
ffprobe ffmpeg
chromium chromium
Xvfb xvfb
xwd x11-apps
xdotool xdotool
npm npm
exiftool libimage-exiftool-perl
python3:ensurepip python3-venv"

# missing: sets $missing_tools and $missing_packages (each package once, in the list's order).
missing() {
  missing_tools="" missing_packages=""
  local tool package
  while read -r tool package; do
    case "$tool" in
      # python3:MODULE: python3 imports MODULE.
      python3:*) python3 -c "import ${tool#python3:}" >/dev/null 2>&1 && continue ;;
      *) command -v "$tool" >/dev/null 2>&1 && continue ;;
    esac
    missing_tools="$missing_tools $tool"
    case " $missing_packages " in *" $package "*) ;; *) missing_packages="$missing_packages $package" ;; esac
  done <<< "$tools"
  missing_tools="${missing_tools# }" missing_packages="${missing_packages# }"
}

missing
if [ -z "$missing_packages" ]; then
  echo "prerequisites: all present (ffmpeg, ffprobe, chromium, Xvfb, xwd, xdotool, npm, exiftool, python3's venv)"
  exit 0
fi
echo "prerequisites: missing $missing_tools (apt packages: $missing_packages)"
[ "$check_only" = 1 ] && exit 1

if [ "$(id -u)" = 0 ]; then
  sudo=""
elif command -v sudo >/dev/null 2>&1; then
  sudo="sudo"
else
  echo "prerequisites: ERROR: not root and no sudo; install them yourself, then run this again:" >&2
  echo "  apt-get install $missing_packages" >&2
  exit 1
fi
if ! command -v apt-get >/dev/null 2>&1; then
  echo "prerequisites: ERROR: no apt-get here; install these packages (Debian's names) yourself: $missing_packages" >&2
  exit 1
fi

echo "prerequisites: installing with ${sudo:+$sudo }apt-get: $missing_packages"
# shellcheck disable=SC2086 # $sudo and the packages are words
if ! { $sudo apt-get update -qq &&
       $sudo env DEBIAN_FRONTEND=noninteractive \
         apt-get install -y -qq --no-install-recommends $missing_packages >/dev/null; }; then
  echo "prerequisites: ERROR: apt-get failed (above); the missing packages: $missing_packages" >&2
  exit 1
fi

missing
if [ -n "$missing_packages" ]; then
  echo "prerequisites: ERROR: still missing after the install: $missing_tools (apt packages: $missing_packages)" >&2
  exit 1
fi
echo "prerequisites: installed; all present now"
