#!/usr/bin/env bash
# Regenerates the viewer screenshots in this folder, headless: Xvfb, the `rerun` viewer of the
# crate's version (pip install rerun-sdk==0.36.3) and its --screenshot-to. Run from the repository
# root after `cargo build --release`; needs Xvfb, ImageMagick and a software Vulkan driver for the
# viewer's renderer without a GPU: apt install xvfb imagemagick mesa-vulkan-drivers.
set -euo pipefail
out=docs/screenshots
bin=target/release/lasercal
work=$(mktemp -d)
trap 'rm -rf "$work"; [ -n "${xvfb:-}" ] && kill "$xvfb" 2>/dev/null || true' EXIT
if [ -z "${DISPLAY:-}" ]; then
  Xvfb :97 -screen 0 1600x1000x24 >/dev/null 2>&1 &
  xvfb=$!
  export DISPLAY=:97
  sleep 2
fi
shot() { # recording, picture
  # The viewer saves the picture, then (0.36.3) may panic while quitting: the file is what counts.
  rm -f "$work/full.png"
  rerun "$1" --screenshot-to "$work/full.png" --window-size 1400x860 >/dev/null 2>&1 || true
  [ -s "$work/full.png" ] || { echo "no screenshot of $1" >&2; exit 1; }
  convert "$work/full.png" -resize 50% "$out/$2"
  echo "$out/$2"
}
$bin run scenarios/chen2018-disk-raycast.toml --rerun "$work/disk.rrd" >/dev/null
shot "$work/disk.rrd" run-disk-raycast.png
$bin run scenarios/comparison.toml --rerun-method edge --rerun "$work/edge.rrd" >/dev/null
shot "$work/edge.rrd" run-edge-raycast.png
# A real-data-like file: 15 free poses of a ball, no groups or signs, calibrated as a user would.
$bin simulate scenarios/ball-free.toml --out "$work/ball.json" >/dev/null
$bin calibrate "$work/ball.json" --rerun "$work/ball.rrd" >/dev/null
shot "$work/ball.rrd" calibrate-ball-free-poses.png
$bin sweep scenarios/chen2018-fig15.toml --trials 200 --out "$work/sweep" --rerun "$work/sweep.rrd" >/dev/null 2>&1
shot "$work/sweep.rrd" sweep-fig15.png
