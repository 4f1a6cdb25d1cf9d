#!/usr/bin/env bash
# Sets everything up (tools/setup.sh) and opens the viewer (release build). Arguments go to the
# viewer, e.g. `bash tools/view.sh scene.ply` or `bash tools/view.sh --test-scene`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
if [ -z "${DISPLAY:-}${WAYLAND_DISPLAY:-}" ]; then
  echo "view: no display; starting the viewer under xvfb-run (nothing will be visible)" >&2
  exec xvfb-run -a cargo run --release -- "$@"
fi
exec cargo run --release -- "$@"
