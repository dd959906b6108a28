#!/usr/bin/env bash
# Builds monohand in the browser (crates/monohand-web) into web/:
#   web/pkg/      the WebAssembly module and its JavaScript glue (wasm-bindgen, --target web)
#   web/pkg-threads/  the same with WebAssembly threads (atomics; rayon's pool on Web
#                 Workers sharing the module's memory) and relaxed SIMD (fused multiply-adds,
#                 the int8 dot product), for cross-origin isolated pages in browsers that
#                 have relaxed SIMD (web/worker.js probes it)
#   web/weights/  MediaPipe's palm detector and hand landmark networks, copied from
#                 `monohand models fetch`'s cache (served beside the page; no CDN)
#   web/webxr-hand/  the WebXR generic hand mesh for the demo page's WebXR view
# and installs what that needs, pinned, when it is missing: the wasm32-unknown-unknown
# target and the standard library's source (rustup: the threaded module rebuilds std with
# atomics) and wasm-bindgen-cli at the exact version of the wasm-bindgen crate
# (crates.io). These folders are build outputs (not committed).
#
#   scripts/web-build.sh                  build (Cargo profile `web`, 4.3 MB), copy the weights
#   WEB_PROFILE=web-fast scripts/...      everything at opt-level 3 (8.3 MB; to compare)
#   WEB_PROFILE=dev scripts/...           a debug build (slow; keeps function names)
#   WEB_THREADS=0 scripts/...             without the threaded module
#   WEB_WEIGHTS=0 scripts/...             the modules only, without copying the weights
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
out_profile="$profile"; [ "$profile" = dev ] && out_profile=debug
# Function names and the producers section are of no use to the page (0.9 MB).
strip=(--remove-name-section --remove-producers-section)
[ "$profile" = dev ] && strip=()

# The threaded module, compiled beside the one-thread module below (two cargo processes:
# each ends in one long single-threaded step, the fat LTO of the whole program, and two
# such steps side by side use both cores). Threads in WebAssembly need the whole program,
# std included, compiled with atomics; the toolchain ships std without them, so std is
# rebuilt from its source (`-Z build-std`, which stable Rust accepts only with
# RUSTC_BOOTSTRAP=1: the way wasm-bindgen-rayon documents, until build-std is stable). Its
# own target folder: other flags than the one-thread module, and its std.
threads_pid=""
threads_log="$target_dir/web-build-threads.log"
rm -rf web/pkg-threads
if [ "${WEB_THREADS:-1}" != 0 ]; then
  rustup component list --installed | grep -q '^rust-src' || rustup component add rust-src
  # The module's memory is shared (imported, so that every worker gets the same one) and
  # the threads' local storage is set up by wasm-bindgen's glue. Linker arguments of the
  # module alone (after `--`): changing them relinks it, not every crate.
  thread_link=()
  for a in --shared-memory --max-memory=1073741824 --import-memory --export=__wasm_init_tls \
           --export=__tls_size --export=__tls_align --export=__tls_base; do
    thread_link+=(-C "link-arg=$a")
  done
  mkdir -p "$target_dir"
  RUSTC_BOOTSTRAP=1 CARGO_TARGET_DIR="$target_dir/wasm-threads" \
    CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUSTFLAGS="-C target-feature=+atomics,+bulk-memory,+simd128,+relaxed-simd" \
    cargo rustc -p monohand-web --features threads --lib --crate-type cdylib \
    --target wasm32-unknown-unknown --profile "$profile" -Z build-std=panic_abort,std -- \
    "${thread_link[@]}" > "$threads_log" 2>&1 &
  threads_pid=$!
fi

# The one-thread module. simd128: tract's WebAssembly matrix kernels need it (every
# current browser has it). Only the wasm32 target gets these flags; the native build is
# untouched.
CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUSTFLAGS="-C target-feature=+simd128" \
  cargo rustc -p monohand-web --lib --crate-type cdylib --target wasm32-unknown-unknown \
  --profile "$profile" || { [ -z "$threads_pid" ] || kill "$threads_pid" 2>/dev/null; exit 1; }
rm -rf web/pkg
wasm-bindgen --target web --no-typescript "${strip[@]}" --out-dir web/pkg \
  "$target_dir/wasm32-unknown-unknown/$out_profile/monohand_web.wasm"

threads_note="no threaded module (WEB_THREADS=0)"
if [ -n "$threads_pid" ]; then
  wait "$threads_pid" ||
    { cat "$threads_log" >&2; echo "web-build: the threaded module did not build (above; $threads_log)" >&2; exit 1; }
  wasm-bindgen --target web --no-typescript "${strip[@]}" --out-dir web/pkg-threads \
    "$target_dir/wasm-threads/wasm32-unknown-unknown/$out_profile/monohand_web.wasm"
  threads_note="web/pkg-threads ($(du -b web/pkg-threads/monohand_web_bg.wasm | cut -f1) bytes)"
fi

# The weights, from the cache (MONOHAND_MODEL_DIR, else XDG_CACHE_HOME or ~/.cache).
# WEB_WEIGHTS=0: the modules only (.ci/run compiles them while the weights may not be
# fetched yet; web-test.sh runs this script again, which then only copies them).
weights_note="web/weights"
if [ "${WEB_WEIGHTS:-1}" != 0 ]; then
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
else
  weights_note="no weights (WEB_WEIGHTS=0)"
fi
# The WebXR generic hand (its two .glb files and licence), which the demo page's WebXR view
# (web/webxr-hand.js: three.js' XRHandMeshModel) loads from web/webxr-hand/ instead of a CDN.
mkdir -p web/webxr-hand
cp crates/monohand-io/assets/webxr-generic-hand/{left.glb,right.glb,LICENSE.md} web/webxr-hand/
echo "web-build: web/pkg ($(du -b web/pkg/monohand_web_bg.wasm | cut -f1) bytes of wasm), $threads_note and $weights_note ready"
