#!/usr/bin/env bash
# Sets up what guava-rs needs beyond cargo, idempotently, on Debian/Ubuntu:
#  - Vulkan (Mesa's software driver lavapipe works without a GPU), Xvfb and the X libraries winit loads;
#  - ONNX Runtime's shared library, from the pinned PyPI wheel, into target/onnxruntime/
#    (the library finds it there; nothing is downloaded at cargo build time);
#  - NumPy for the Python tools the tests run (tools/convert_ehm_tracking.py reads NumPy pickles).
set -euo pipefail
cd "$(dirname "$0")/.."

APT_PACKAGES=(mesa-vulkan-drivers libvulkan1 xvfb imagemagick libxkbcommon-x11-0 libx11-xcb1
  libxcursor1 libxi6 libxrandr2 libegl1 unzip)
ORT_VERSION=1.32.0
ORT_WHEEL=onnxruntime-1.32.0-cp311-cp311-manylinux_2_28_x86_64.whl
ORT_SHA256=5a34fc4dfeb5a7b4a74c95dcba1e773d722abda720b474edf1b0c419dc6d163d
ORT_DIR=target/onnxruntime

missing=()
for p in "${APT_PACKAGES[@]}"; do
  dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
if ((${#missing[@]})); then
  sudo=""
  [ "$(id -u)" = 0 ] || sudo="sudo"
  if ! command -v apt-get >/dev/null; then
    echo "setup: please install the equivalents of: ${missing[*]}" >&2
    exit 1
  fi
  echo "setup: installing ${missing[*]}"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

if [ ! -f "$ORT_DIR/libonnxruntime.so.$ORT_VERSION" ]; then
  echo "setup: installing ONNX Runtime $ORT_VERSION into $ORT_DIR"
  mkdir -p "$ORT_DIR"
  # One exact wheel whatever the local Python: the shared library inside is the same for all.
  python3 -m pip download --quiet --no-deps --only-binary=:all: --python-version 3.11 \
    --implementation cp --platform manylinux_2_28_x86_64 "onnxruntime==$ORT_VERSION" -d "$ORT_DIR"
  echo "$ORT_SHA256  $ORT_DIR/$ORT_WHEEL" | sha256sum --check --quiet
  unzip -q -o -j "$ORT_DIR/$ORT_WHEEL" "onnxruntime/capi/libonnxruntime.so.$ORT_VERSION" -d "$ORT_DIR"
  rm "$ORT_DIR/$ORT_WHEEL"
fi
ln -sf "libonnxruntime.so.$ORT_VERSION" "$ORT_DIR/libonnxruntime.so"

if ! python3 -c "import numpy" 2>/dev/null; then
  echo "setup: installing NumPy for the Python tools"
  python3 -m pip install --quiet "numpy>=1.26" ||
    python3 -m pip install --quiet --user --break-system-packages "numpy>=1.26"
fi
