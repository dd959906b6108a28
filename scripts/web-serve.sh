#!/usr/bin/env bash
# Builds monohand for the browser (scripts/web-build.sh: web/pkg and web/weights) and serves
# the demo page, web/index.html, on this machine only:
#
#   scripts/web-serve.sh            http://localhost:8000/
#   PORT=8080 scripts/web-serve.sh
#
# Open the address in a browser, press "Start camera" (or open a video file). Browsers give
# the camera only to pages served over https or from localhost, so open it as localhost on
# this machine (not by another machine's address over plain http). Needs what web-build.sh
# needs, npm (three.js for the 3D view, and TypeScript, from web/package-lock.json) and
# python3 (its http.server). Stop with Ctrl-C.
#
# The server sends the two headers that make the page cross-origin isolated
# (Cross-Origin-Opener-Policy: same-origin, Cross-Origin-Embedder-Policy: require-corp), so
# that the tracker can use WebAssembly threads; a server without them gets the one-thread
# module, and the page says so once. Serve the page with them in production too.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/web-build.sh
# three.js for the page's 3D view (pinned in web/package-lock.json; the page works without).
npm ci --prefix web --no-audit --no-fund --loglevel=error > /dev/null
port="${PORT:-8000}"
echo "web-serve: the demo page is at http://localhost:$port/ (Ctrl-C stops)"
exec python3 - "$port" web <<'PY'
import functools, http.server, sys

class Isolated(http.server.SimpleHTTPRequestHandler):
    def end_headers(self):
        self.send_header("Cross-Origin-Opener-Policy", "same-origin")
        self.send_header("Cross-Origin-Embedder-Policy", "require-corp")
        super().end_headers()

handler = functools.partial(Isolated, directory=sys.argv[2])
try:
    http.server.ThreadingHTTPServer(("127.0.0.1", int(sys.argv[1])), handler).serve_forever()
except KeyboardInterrupt:
    pass
PY
