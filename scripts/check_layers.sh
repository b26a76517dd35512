#!/usr/bin/env bash
# The layer rule (docs/design.md): a file in include/smoketrace/<layer>/ or src/<layer>/ includes only
# headers of its own layer and of the layers before it, in this order. Also: no header or source outside a
# layer folder (but the umbrella header), and no Embree in the library or the command line.
# Prints every violation and exits 1 if there is any; run by ctest as "layers".
set -euo pipefail
root="$(cd "${1:-$(dirname "$0")/..}" && pwd)"
layers=(core geometry accel trace smoke render textbook truth io)
rank() { local i; for i in "${!layers[@]}"; do [ "${layers[$i]}" = "$1" ] && { echo "$i"; return; }; done; echo -1; }

bad=0
report() { echo "layers: $*"; bad=1; }

cd "$root"
for f in include/smoketrace/*.hpp src/*.cpp; do
  [ -e "$f" ] || continue
  [ "$f" = include/smoketrace/smoketrace.hpp ] && continue
  report "$f is not in a layer folder (${layers[*]})"
done
for dir in include/smoketrace/*/ src/*/; do
  layer=$(basename "$dir")
  [ "$(rank "$layer")" -ge 0 ] || report "$dir is not a layer (${layers[*]})"
done

checked=0
while IFS= read -r f; do
  layer=$(echo "$f" | sed -E 's#^(include/smoketrace|src)/([a-z]+)/.*#\2#')
  own=$(rank "$layer")
  [ "$own" -ge 0 ] || continue
  checked=$((checked + 1))
  while IFS=: read -r line used; do
    r=$(rank "$used")
    if [ "$r" -lt 0 ]; then report "$f:$line includes smoketrace/$used/, which is not a layer"
    elif [ "$r" -gt "$own" ]; then report "$f:$line ($layer) includes smoketrace/$used/, a later layer"; fi
  done < <(grep -nE '^[[:space:]]*#[[:space:]]*include[[:space:]]*[<"]smoketrace/' "$f" |
             sed -E 's#^([0-9]+):.*smoketrace/([a-z]+)/.*#\1:\2#; t; s#^([0-9]+):.*#\1:(none)#')
done < <(find include/smoketrace src -mindepth 2 -type f \( -name '*.hpp' -o -name '*.cpp' \) | sort)

if grep -rnE '^[[:space:]]*#[[:space:]]*include[[:space:]]*[<"]embree' include src apps 2>/dev/null; then
  report "the library and the command line must not include Embree (tests, bench and one example only)"
fi
[ "$checked" -gt 0 ] || report "no file checked under include/smoketrace/*/ or src/*/"
[ "$bad" = 0 ] && echo "layers: $checked files follow the rule (${layers[*]})"
exit "$bad"
