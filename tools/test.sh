#!/usr/bin/env bash
# Sets everything up (tools/setup.sh) and runs the whole test suite: library, CLI, GPU passes on
# whatever Vulkan adapter is present (lavapipe without a GPU), ONNX Runtime, and the viewer in a
# real window under Xvfb. README's test command; .ci/run calls exactly this.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
# lavapipe and winit want a runtime dir; any writable one will do.
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
cargo test --workspace "$@"
