#!/usr/bin/env bash
# Set-up, build, and the main job: the thesis's two default scenes (figures 5.1 and 5.2: light from above
# and from the right) in all three render modes, and a short sequence with a turning light, written to out/.
# Only the packages and the targets the demo runs are installed and built (scripts/test.sh does the rest),
# and the image to open first is rendered first.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
"$root/scripts/setup.sh" --demo
"$root/scripts/build.sh" --demo
bin="${SMOKETRACE_BUILD_DIR:-$root/build}/smoketrace"
out="$root/out"
mkdir -p "$out"
# Scene $1 in mode $2 at 1024x1024; the command says what it wrote (standard error), then the frame's time.
render() {
  "$bin" render "$root/assets/scenes/$1.json" -o "$out/${1}_$2.png" --mode "$2" --size 1024x1024 --timings \
    | sed -n 's/^total=/  total ms=/p'
}
render two_tubes_above full  # the image to open first
for scene in two_tubes_above two_tubes_right; do
  for mode in basic simple-shadow full; do
    [ "$scene $mode" = "two_tubes_above full" ] || render "$scene" "$mode"
  done
  "$bin" depths "$root/assets/scenes/$scene.json" -o "$out/${scene}_depths.csv"
done
# A short sequence (thesis 5.2.2): the light turns 3.5° per frame from the right up to above, particles drift
# and spin, 4 groups; frame by frame, then as one animated PNG (the same frames, rendered again).
sequence="$root/assets/scenes/two_tubes_sequence.json"
mkdir -p "$out/sequence"
"$bin" render "$sequence" -o "$out/sequence/frame.png" --size 512x512 --frames 24 --timings \
  | sed -n '/^median/,$p' | sed -n 's/^total=/  sequence median total ms=/p'
"$bin" render "$sequence" -o "$out/sequence.apng" --size 512x512 --frames 24

cat <<TEXT

Written to $out/; open two_tubes_above_full.png first, then sequence.apng in a web browser.
  two_tubes_above_*.png, two_tubes_right_*.png  the thesis's two scenes (figures 5.1 and 5.2: light from above,
                            from the right) in the three render modes: basic (no optical depths, no shadows),
                            simple-shadow (shadows 0 or 1), full (shadows and darkening by optical depth)
  sequence.apng             the 24-frame sequence as an animated PNG; a web browser plays it, other viewers
                            show its first frame
  sequence/frame_*.png      the same sequence, one PNG per frame
  *_depths.csv              every particle's optical depth toward the light: one row per particle
TEXT
