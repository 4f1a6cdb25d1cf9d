#!/usr/bin/env bash
# Times our splatting pass and web-splat's (KeKsBoTer/web-splat, Rust + wgpu: GPU radix sort and
# instanced quads) side by side on this host, the peer comparison of README's Performance section.
# Both draw the same PLY (random Gaussians in a unit ball, `guava bench splat --write-ply`) from
# (0, 0, −3) at 50°, 512², medians of 9 frames after two warm-ups; rounds alternate the two so a
# drifting shared host hits both alike. Only ratios within one round compare.
#
#   bash tools/compare_websplat.sh [--src DIR] [--rounds N] [--count N]
#
# --src DIR: a folder with clones of web-splat, cgmath (rustgd) and splines (KeKsBoTer), web-splat's
# two git dependencies; without it they are cloned from GitHub. Each is checked out at the commit
# below, its git dependencies pointed at the others, and tools/websplat_compare/guava_compare.rs
# added as a binary; everything is built under target/websplat (a first build takes ~8 min on
# 2 cores). Not part of the tests: it needs web-splat's sources, which no package registry has.
set -euo pipefail
cd "$(dirname "$0")/.."

src="" rounds=3 count=150000
while [ $# -gt 0 ]; do
  case "$1" in
    --src) src="$(cd "$2" && pwd)"; shift 2 ;;
    --rounds) rounds="$2"; shift 2 ;;
    --count) count="$2"; shift 2 ;;
    *) echo "compare_websplat: unknown argument '$1'" >&2; exit 2 ;;
  esac
done

work=target/websplat
mkdir -p "$work"
checkout() { # name, GitHub owner, commit
  local dir="$work/$1" origin="${src:+$src/$1}"
  origin="${origin:-https://github.com/$2/$1}"
  [ -d "$dir/.git" ] || git clone -q "$origin" "$dir"
  git -C "$dir" checkout -q -f "$3" || {
    echo "compare_websplat: $origin has no commit $3" >&2
    exit 1
  }
}
checkout web-splat KeKsBoTer 959a3ecc2b649a2677fa6c56f4a1a19eb4c3fc80
checkout cgmath rustgd ff840cbf48d79441eaac3e78155df4723511d247
checkout splines KeKsBoTer cdb1be6c7ffbfc5eee0aca91df405c62b62b2c0a

# Git dependencies → the checkouts; only the PNG and JPEG codecs (the default set triples the
# build); no wasm-bindgen-cli, which only web-splat's wasm build uses.
sed -i -e "s|git = 'https://github.com/rustgd/cgmath'|path = \"../cgmath\"|" \
  -e 's|git = "https://github.com/KeKsBoTer/splines"|path = "../splines"|' \
  -e 's|^image = "0.25.6"|image = { version = "0.25.6", default-features = false, features = ["png", "jpeg"] }|' \
  -e '/^wasm-bindgen-cli/d' "$work/web-splat/Cargo.toml"
sed -i "s|git = 'https://github.com/rustgd/cgmath'|path = \"../cgmath\"|" "$work/splines/Cargo.toml"
if grep -q "git = " "$work/web-splat/Cargo.toml" "$work/splines/Cargo.toml"; then
  echo "compare_websplat: a git dependency was not redirected (upstream Cargo.toml changed?)" >&2
  exit 1
fi
# Its own workspace: target/websplat sits inside ours.
printf '\n[workspace]\n\n[[bin]]\nname = "guava_compare"\n' >>"$work/web-splat/Cargo.toml"
cp tools/websplat_compare/guava_compare.rs "$work/web-splat/src/bin/guava_compare.rs"

echo "building web-splat's harness and guava (release)…" >&2
cargo build -q --release --manifest-path "$work/web-splat/Cargo.toml" --bin guava_compare
cargo build -q --release -p guava-cli
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
peer="$work/web-splat/target/release/guava_compare"
guava=target/release/guava

ply="$work/ply/ball_${count}_c3.ply"
"$guava" bench splat --counts "$count" --sizes 512 --channels 3 --frames 1 --write-ply "$work/ply" >/dev/null

# Our frame time for C channels from the bench table (its last-but-one column).
frame_ms() { awk -v c="$2" '$1 ~ /^[0-9]+$/ && $3 == c { print $(NF - 1) }' <<<"$1"; }

printf '%s Gaussians, 512², medians of 9 frames; ratios are ours / web-splat RGB in the same round\n' "$count"
for round in $(seq 1 "$rounds"); do
  save=() # the first round also saves web-splat's frame, to check it drew the whole ball
  [ "$round" != 1 ] || save=("$work/websplat_frame.png")
  peer_out="$("$peer" "$ply" 9 "${save[@]}")"
  ours="$("$guava" bench splat --counts "$count" --sizes 512 --channels 3,32 --frames 9)"
  if [ "$round" = 1 ]; then
    echo "web-splat $(grep '^adapter' <<<"$peer_out")"
    echo "guava     $(grep '^adapter' <<<"$ours")"
    printf '%-6s %12s %12s %7s %12s %7s\n' round web-splat "ours 3 ch" ratio "ours 32 ch" ratio
  fi
  peer_ms="$(awk '/median/ { print $3 }' <<<"$peer_out")"
  rgb_ms="$(frame_ms "$ours" 3)" c32_ms="$(frame_ms "$ours" 32)"
  awk -v r="$round" -v p="$peer_ms" -v a="$rgb_ms" -v b="$c32_ms" \
    'BEGIN { printf "%-6s %9.1f ms %9.1f ms %7.2f %9.1f ms %7.2f\n", r, p, a, a / p, b, b / p }'
done
echo "web-splat's first frame: $work/websplat_frame.png" >&2
