#!/usr/bin/env bash
# The benchmark finds its inputs without the source tree's path (bench/bench_assets.hpp), checked with
# --dry-run (it resolves the options and the assets folder, then stops) on copies of the binary:
#   * beside it in a packed folder (bin/smoketrace_bench, assets/), run directly and through the dynamic
#     loader (as a bundle's own loader runs it: the running binary is then the loader, argv[0] the bench);
#   * named by --assets and by SMOKETRACE_ASSETS, --assets first;
#   * a folder given that is none, or lacks a file, is an error naming it;
#   * a section that reads no assets does not look for them; a bad --thread-counts or --repeats is an error.
#     bench_assets.sh BENCH SOURCE_ASSETS
set -euo pipefail
bench="$1"; source_assets="$2"
tmp="$(cd "$(mktemp -d)" && pwd -P)"  # the binary's path comes back with links resolved
trap 'rm -rf "$tmp"' EXIT
unset SMOKETRACE_ASSETS

fail() { echo "FAIL: $1"; shift; printf '%s\n' "$@"; exit 1; }
# expect_line WHAT EXPECTED COMMAND...: the command succeeds and its output has the line EXPECTED.
expect_line() {
  local what="$1" want="$2"; shift 2
  local out
  out=$("$@" 2>&1) || fail "$what: exit $?" "$out"
  grep -qxF -- "$want" <<<"$out" || fail "$what: no line '$want'" "$out"
}
# expect_error WHAT EXPECTED COMMAND...: the command exits with 2 and its error holds EXPECTED.
expect_error() {
  local what="$1" want="$2"; shift 2
  local out rc=0
  out=$("$@" 2>&1) || rc=$?
  [ "$rc" = 2 ] || fail "$what: exit $rc, not 2" "$out"
  grep -qF -- "$want" <<<"$out" || fail "$what: the error does not say '$want'" "$out"
}

# A packed folder: the binary in bin/, the assets beside bin/ (without the plots, as a bundle copies them).
mkdir -p "$tmp/pack/bin" "$tmp/alone" "$tmp/empty"
cp "$bench" "$tmp/pack/bin/smoketrace_bench"
cp "$bench" "$tmp/alone/smoketrace_bench"
cp -r "$source_assets" "$tmp/pack/assets"
rm -rf "$tmp/pack/assets/plots"
packed="$tmp/pack/bin/smoketrace_bench"

expect_line "packed folder" "assets: $tmp/pack/assets (beside the binary $packed)" \
  "$packed" --dry-run --section view
loader=$(ldd "$bench" | awk '/ld-linux/ { print $1 }')
if [ -n "$loader" ] && [ -x "$loader" ]; then
  expect_line "packed folder, through the loader" "assets: $tmp/pack/assets (beside the binary $packed)" \
    "$loader" "$packed" --dry-run --section view
else
  echo "no dynamic loader named by ldd: the run through the loader is not checked"
fi

alone="$tmp/alone/smoketrace_bench"
expect_line "--assets" "assets: $tmp/pack/assets (--assets)" \
  "$alone" --dry-run --section view --assets "$tmp/pack/assets"
expect_line "SMOKETRACE_ASSETS" "assets: $tmp/pack/assets (SMOKETRACE_ASSETS)" \
  env SMOKETRACE_ASSETS="$tmp/pack/assets" "$alone" --dry-run --section truth
expect_line "--assets before SMOKETRACE_ASSETS" "assets: $tmp/pack/assets (--assets)" \
  env SMOKETRACE_ASSETS="$tmp/nowhere" "$alone" --dry-run --assets "$tmp/pack/assets"
expect_line "a section without assets" "assets: (not needed)" "$alone" --dry-run --section bvh

expect_error "--assets: not a folder" "--assets: '$tmp/nowhere' is not a folder" \
  "$alone" --dry-run --assets "$tmp/nowhere"
expect_error "--assets: an empty folder" "--assets: '$tmp/empty' holds no sixway.json" \
  "$alone" --dry-run --section view --assets "$tmp/empty"
cp "$source_assets/sixway.json" "$tmp/empty/"
expect_error "--assets: a folder without the scenes" "holds no scenes/two_tubes_above.json" \
  "$alone" --dry-run --section view --assets "$tmp/empty"
expect_error "SMOKETRACE_ASSETS: not a folder" "SMOKETRACE_ASSETS: '$tmp/nowhere' is not a folder" \
  env SMOKETRACE_ASSETS="$tmp/nowhere" "$alone" --dry-run --section view

expect_line "--thread-counts" "thread counts of section threads: 1 3 8" "$alone" --dry-run --thread-counts 8,3,8
expect_error "--thread-counts: not a count" "--thread-counts: '0' in '2,0' is not a thread count" \
  "$alone" --dry-run --thread-counts 2,0
expect_line "--repeats" "repeats: 7" "$alone" --dry-run --repeats 7
expect_error "--repeats: not a whole number" "--repeats: '3x' is not a whole number from 1 to 1000" \
  "$alone" --dry-run --repeats 3x
expect_error "--repeats: zero" "--repeats: '0' is not a whole number" "$alone" --dry-run --repeats 0
echo "ok"
