#!/usr/bin/env bash
# The layer rule (docs/design.md): a file in include/smoketrace/<layer>/ or src/<layer>/ includes only
# headers of its own layer and of the layers before it, in this order. Also: no header or source outside a
# layer folder (but the umbrella header), and no Embree in the library or the command line. And the wings:
# the textbook (textbook/) includes only its allow-list and itself, and only the textbook, the command
# line, the tests and the bench include it, so the fast path never leans on it; io reads and writes the
# six-way textures of render/ but includes nothing else of it; `depths` includes nothing of render/ (its
# --truth reaches the six-way puff through truth/ and io/).
# Prints every violation and exits 1 if there is any; run by ctest as "layers".
set -euo pipefail
root="$(cd "${1:-$(dirname "$0")/..}" && pwd)"
layers=(core geometry accel trace smoke render textbook truth io)
rank() { local i; for i in "${!layers[@]}"; do [ "${layers[$i]}" = "$1" ] && { echo "$i"; return; }; done; echo -1; }
# What the textbook may include beside itself: plain data and plain geometry, no traversal, no lanes.
textbook_allowed=(core/image.hpp core/prng.hpp
  geometry/aabb.hpp geometry/ray.hpp geometry/ray_sphere.hpp geometry/ray_triangle.hpp
  accel/accel_scene.hpp accel/bvh.hpp accel/instance.hpp accel/sphere_set.hpp accel/triangle_mesh.hpp
  accel/trace_types.hpp accel/any_hit.hpp
  smoke/particle_system.hpp smoke/scene_description.hpp smoke/density_kernel.hpp smoke/stand_in_shapes.hpp
  smoke/smoke_scene.hpp smoke/particle_groups.hpp smoke/light_ray.hpp
  render/camera.hpp render/pixel_samples.hpp render/sixway_texture.hpp)
# What io may include of render/: the six-way texture data it reads and writes.
io_render_allowed=(render/sixway_texture.hpp render/sixway_baker.hpp)
listed() { local want="$1" x; shift; for x in "$@"; do [ "$x" = "$want" ] && return 0; done; return 1; }

bad=0
report() { echo "layers: $*"; bad=1; }
# `line:header` for each smoketrace include of file $1 (header: e.g. core/image.hpp, or (none)).
includes() {
  grep -nE '^[[:space:]]*#[[:space:]]*include[[:space:]]*[<"]smoketrace/' "$1" |
    sed -E 's#^([0-9]+):.*smoketrace/([a-z_]+/[^>"]*)[>"].*#\1:\2#; t; s#^([0-9]+):.*#\1:(none)#' || true
}

cd "$root"
for f in include/smoketrace/*.hpp src/*.cpp; do
  [ -e "$f" ] || continue
  [ "$f" = include/smoketrace/smoketrace.hpp ] && continue
  report "$f is not in a layer folder (${layers[*]})"
done
for dir in include/smoketrace/*/ src/*/; do
  [ -d "$dir" ] || continue
  layer=$(basename "$dir")
  [ "$(rank "$layer")" -ge 0 ] || report "$dir is not a layer (${layers[*]})"
done

checked=0
while IFS= read -r f; do
  layer=$(echo "$f" | sed -E 's#^(include/smoketrace|src)/([a-z]+)/.*#\2#')
  own=$(rank "$layer")
  [ "$own" -ge 0 ] || continue
  checked=$((checked + 1))
  while IFS=: read -r line header; do
    [ -n "$line" ] || continue
    used=${header%%/*}
    r=$(rank "$used")
    if [ "$r" -lt 0 ]; then report "$f:$line includes smoketrace/$used/, which is not a layer"
    elif [ "$r" -gt "$own" ]; then report "$f:$line ($layer) includes smoketrace/$used/, a later layer"
    elif [ "$layer" = textbook ] && [ "$used" != textbook ] && ! listed "$header" "${textbook_allowed[@]}"; then
      report "$f:$line (textbook) includes smoketrace/$header, which is not on the textbook's list"
    elif [ "$layer" = io ] && [ "$used" = render ] && ! listed "$header" "${io_render_allowed[@]}"; then
      report "$f:$line (io) includes smoketrace/$header, a render internal (io may use ${io_render_allowed[*]})"
    fi
  done < <(includes "$f")
done < <(find include/smoketrace src -mindepth 2 -type f \( -name '*.hpp' -o -name '*.cpp' \) | sort)

# The textbook is plain C++: no intrinsics.
while IFS= read -r hit; do report "$hit: the textbook includes intrinsics"; done < <(
  grep -rnE '^[[:space:]]*#[[:space:]]*include[[:space:]]*<[a-z0-9]*intrin\.h>' include/smoketrace/textbook src/textbook \
    2>/dev/null | cut -d: -f1-2 || true)
# Only the textbook itself, the command line, the tests and the bench include the textbook.
while IFS= read -r hit; do
  case "$hit" in
    include/smoketrace/textbook/* | src/textbook/*) ;;
    *) report "$hit: only the textbook, apps/, tests/ and bench/ include smoketrace/textbook/" ;;
  esac
done < <(grep -rnE '^[[:space:]]*#[[:space:]]*include[[:space:]]*[<"]smoketrace/textbook/' include src examples 2>/dev/null |
           cut -d: -f1-2 || true)

# `depths` and the command-line headers it includes: nothing of render/.
depths=apps/cli/cmd_depths.cpp
if [ -e "$depths" ]; then
  for f in "$depths" $(grep -oE '^[[:space:]]*#[[:space:]]*include[[:space:]]*"[a-z_]+\.hpp"' "$depths" |
                         sed -E 's#.*"(.*)"#apps/cli/\1#'); do
    [ -e "$f" ] || continue
    while IFS=: read -r line header; do
      [ "${header%%/*}" = render ] && report "$f:$line includes smoketrace/$header: depths needs nothing of render/"
    done < <(includes "$f")
  done
fi

if grep -rnE '^[[:space:]]*#[[:space:]]*include[[:space:]]*[<"]embree' include src apps 2>/dev/null; then
  report "the library and the command line must not include Embree (tests, bench and one example only)"
fi
[ "$checked" -gt 0 ] || report "no file checked under include/smoketrace/*/ or src/*/"
[ "$bad" = 0 ] && echo "layers: $checked files follow the rule (${layers[*]})"
exit "$bad"
