#!/usr/bin/env bash
# Builds monohand in the browser (crates/monohand-web) into web/:
#   web/pkg/      the WebAssembly module and its JavaScript glue (wasm-bindgen, --target web)
#   web/weights/  MediaPipe's palm detector and hand landmark networks, copied from
#                 `monohand models fetch`'s cache (served beside the page; no CDN)
# and installs what that needs, pinned, when it is missing: the wasm32-unknown-unknown
# target (rustup) and wasm-bindgen-cli at the exact version of the wasm-bindgen crate
# (crates.io). Both folders are build outputs (not committed).
#
#   scripts/web-build.sh                  build (Cargo profile `web`, 4.3 MB), copy the weights
#   WEB_PROFILE=web-fast scripts/...      everything at opt-level 3 (8.3 MB; to compare)
#   WEB_PROFILE=dev scripts/...           a debug build (slow; keeps function names)
set -euo pipefail
cd "$(dirname "$0")/.."

# The version the crate pins (crates/monohand-web/Cargo.toml: wasm-bindgen = "=X").
bindgen_version="$(sed -n 's/^wasm-bindgen = "=\([0-9.]*\)"/\1/p' crates/monohand-web/Cargo.toml)"
[ -n "$bindgen_version" ] || { echo "web-build: no pinned wasm-bindgen version in crates/monohand-web/Cargo.toml" >&2; exit 1; }

if ! rustup target list --installed | grep -qx wasm32-unknown-unknown; then
  rustup target add wasm32-unknown-unknown
fi
if [ "$(wasm-bindgen --version 2>/dev/null | awk '{print $2}')" != "$bindgen_version" ]; then
  # Without --locked: the tool's own lock file can name versions newer than a registry
  # mirror has; the tool's version itself is pinned.
  cargo install wasm-bindgen-cli --version "$bindgen_version"
fi

profile="${WEB_PROFILE:-web}"
target_dir="${CARGO_TARGET_DIR:-target}"
# simd128: tract's WebAssembly matrix kernels need it (every current browser has it).
# Only the wasm32 target gets these flags; the native build is untouched.
export CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUSTFLAGS="-C target-feature=+simd128"
cargo rustc -p monohand-web --lib --crate-type cdylib --target wasm32-unknown-unknown \
  --profile "$profile"
out_profile="$profile"; [ "$profile" = dev ] && out_profile=debug
# Function names and the producers section are of no use to the page (0.9 MB).
strip=(--remove-name-section --remove-producers-section)
[ "$profile" = dev ] && strip=()
rm -rf web/pkg
wasm-bindgen --target web --no-typescript "${strip[@]}" --out-dir web/pkg \
  "$target_dir/wasm32-unknown-unknown/$out_profile/monohand_web.wasm"

# The weights, from the cache (MONOHAND_MODEL_DIR, else XDG_CACHE_HOME or ~/.cache).
models="${MONOHAND_MODEL_DIR:-${XDG_CACHE_HOME:-$HOME/.cache}/monohand/models}"
mkdir -p web/weights
for f in palm_detection_full.tflite palm_detection_lite.tflite \
         hand_landmark_full.tflite hand_landmark_lite.tflite LICENSE.mediapipe.txt; do
  if [ ! -f "$models/$f" ]; then
    echo "web-build: $models/$f is missing: run \`monohand models fetch\` first" \
         "(cargo run -p monohand-cli -- models fetch)" >&2
    exit 1
  fi
  cp "$models/$f" web/weights/
done
echo "web-build: web/pkg ($(du -b web/pkg/monohand_web_bg.wasm | cut -f1) bytes of wasm) and web/weights ready"
