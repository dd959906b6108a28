#!/usr/bin/env bash
# The README's pictures, made from the shipped sample photo so that they stay true:
#   docs/images/overlay.png  the depth overlay (shaded 3D bones, top view, labels)
#   docs/images/gltf.png     the skinned glTF hand rendered by three.js in headless Chromium
# Needs what the tests need: ffmpeg-free (one image), chromium and npm (three.js is
# installed into a temporary folder, not kept).
set -euo pipefail
cd "$(dirname "$0")/.."
out=docs/images
mkdir -p "$out"
tmp="$(mktemp -d)"
server=""
cleanup() { [ -n "$server" ] && kill "$server" 2>/dev/null; rm -rf "$tmp"; }
trap cleanup EXIT

cargo build --release -q -p monohand-cli
bin="${CARGO_TARGET_DIR:-target}/release/monohand"
photo=examples/data/hand.png
read -r w h < <(python3 -c "import struct,sys; d=open('$photo','rb').read(24); print(*struct.unpack('>II', d[16:24]))")

"$bin" camera --width "$w" --height "$h" > "$tmp/cam.json"
mkdir -p "$tmp/site"
"$bin" run "$photo" --camera "$tmp/cam.json" -o "$tmp/hand.jsonl" \
  --overlay "$out/overlay.png" --gltf "$tmp/site/hands.glb"

npm install --no-audit --no-fund --silent --prefix "$tmp/site" three@0.170.0
cat > "$tmp/site/index.html" <<HTML
<!doctype html><html><head><style>html,body{margin:0;background:#202428;overflow:hidden}</style>
<script type="importmap">{"imports": {"three": "./node_modules/three/build/three.module.js",
"three/addons/": "./node_modules/three/examples/jsm/"}}</script></head>
<body><canvas id="c" width="$w" height="$h"></canvas>
<script type="module">
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
const renderer = new THREE.WebGLRenderer({canvas: document.getElementById('c'), antialias: true});
renderer.setPixelRatio(1);
renderer.setSize($w, $h, false);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x202428);
scene.add(new THREE.AmbientLight(0xffffff, 0.8));
const sun = new THREE.DirectionalLight(0xffffff, 2.5);
sun.position.set(-1, 1, 1);
scene.add(sun);
new GLTFLoader().load('hands.glb', (g) => {
  scene.add(g.scene);
  g.scene.traverse((o) => { o.frustumCulled = false; });
  const mixer = new THREE.AnimationMixer(g.scene);
  for (const a of g.animations) mixer.clipAction(a).play();
  mixer.setTime(0);
  scene.updateMatrixWorld(true);
  // Seen from the side: a camera to the right of the real one, looking at the hand.
  let mid = null;
  g.scene.traverse((o) => { if (!mid && o.name.startsWith('middle-finger-phalanx-proximal_')) mid = o; });
  const c = new THREE.Vector3(); mid.getWorldPosition(c);
  const cam = new THREE.PerspectiveCamera(40, $w / $h, 0.01, 10);
  cam.position.set(c.x + 0.25, c.y + 0.12, c.z + 0.25);
  cam.lookAt(c);
  renderer.render(scene, cam);
});
</script></body></html>
HTML
port=$((20000 + RANDOM % 20000))
(cd "$tmp/site" && exec python3 -m http.server "$port" --bind 127.0.0.1 >/dev/null 2>&1) &
server=$!
sleep 1
chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
  --disable-background-networking --disable-component-update --disable-sync \
  --use-angle=swiftshader --enable-unsafe-swiftshader --hide-scrollbars \
  --window-size="$w,$h" --virtual-time-budget=20000 --user-data-dir="$tmp/profile" \
  --screenshot="$out/gltf.png" "http://127.0.0.1:$port/index.html" 2>/dev/null
echo "wrote $out/overlay.png and $out/gltf.png"
