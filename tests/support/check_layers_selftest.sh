#!/usr/bin/env bash
# The layer check must catch what it is for: run on a small tree with one upward include, one flat header,
# one include into a folder that is no layer, a textbook file off its list, the fast path leaning on the
# textbook and io on a render internal, it must fail and name each; on the same tree mended, pass.
set -euo pipefail
check="$1"
tree="$(mktemp -d)"
trap 'rm -rf "$tree"' EXIT
mkdir -p "$tree/include/smoketrace/core" "$tree/include/smoketrace/io" "$tree/src/geometry" "$tree/src/textbook" \
         "$tree/src/smoke" "$tree/src/io"
echo '#include <smoketrace/io/png_io.hpp>' > "$tree/include/smoketrace/core/image.hpp"
echo '#include <smoketrace/core/image.hpp>' > "$tree/include/smoketrace/io/png_io.hpp"
echo '#include <smoketrace/util/misc.hpp>' > "$tree/src/geometry/ray.cpp"
echo '#pragma once' > "$tree/include/smoketrace/flat.hpp"
printf '#include <smoketrace/core/image.hpp>\n#include <smoketrace/trace/trace.hpp>\n' > "$tree/src/textbook/trace.cpp"
echo '#include <smoketrace/textbook/trace.hpp>' > "$tree/src/smoke/pass.cpp"
echo '#include <smoketrace/render/camera.hpp>' > "$tree/src/io/scene_file.cpp"
if out=$(bash "$check" "$tree"); then echo "the check passed a tree that breaks the rule:"; echo "$out"; exit 1; fi
for expect in "core/image.hpp:1 (core) includes smoketrace/io/" "flat.hpp is not in a layer folder" \
              "ray.cpp:1 includes smoketrace/util/, which is not a layer" \
              "trace.cpp:2 (textbook) includes smoketrace/trace/trace.hpp, which is not on the textbook's list" \
              "src/smoke/pass.cpp:1: only the textbook" "scene_file.cpp:1 (io) includes smoketrace/render/camera.hpp"; do
  grep -qF "$expect" <<<"$out" || { echo "missing: $expect"; echo "$out"; exit 1; }
done
echo '#pragma once' > "$tree/include/smoketrace/core/image.hpp"
echo '#include <smoketrace/core/image.hpp>' > "$tree/src/geometry/ray.cpp"
rm "$tree/include/smoketrace/flat.hpp" "$tree/src/smoke/pass.cpp"
echo '#include <smoketrace/core/image.hpp>' > "$tree/src/textbook/trace.cpp"
echo '#include <smoketrace/core/image.hpp>' > "$tree/src/io/scene_file.cpp"
bash "$check" "$tree"
