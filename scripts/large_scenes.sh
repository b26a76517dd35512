#!/usr/bin/env bash
# Measures the large particle scenes of issue #12: the thesis's two tubes as explicit particles (radius
# 0.35*sqrt(750/N), no cutoff), 1M from a JSON scene file written two ways and 10M from a PLY point cloud,
# through `smoketrace depths --timings` under /usr/bin/time -v. The two JSON files hold the same particles:
# tubes_N.json as our own writer writes it (floats' shortest decimals, a particle per line, the origin given),
# tubes_N_exporter.json as a simulation's exporter in Python would (json.dump: doubles' shortest decimals, one
# line, no origin; bench/make_particle_scene.cpp). Prints, per scene: wall time, peak resident memory, user and
# system CPU time, page faults, and the stages (read_scene, tlas_update, od_pass, resolve, write_csv) with each
# one's wall time, minor page faults and system time.
# Builds only smoketrace_cli and make_particle_scene (in build/, or SMOKETRACE_BUILD_DIR); the scenes are
# written once into LARGE_SCENES_DIR (default build/large-scenes; 1M JSON ~100 MB and ~140 MB, 10M PLY 160 MB).
# Environment: LARGE_JSON_COUNT (default 1000000), LARGE_PLY_COUNT (default 10000000), SMOKETRACE_JOBS.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${SMOKETRACE_BUILD_DIR:-$root/build}"
scenes="${LARGE_SCENES_DIR:-$build/large-scenes}"
json_count="${LARGE_JSON_COUNT:-1000000}"
ply_count="${LARGE_PLY_COUNT:-10000000}"
[ -x /usr/bin/time ] || { echo "large_scenes: /usr/bin/time not found (Debian: apt-get install time)" >&2; exit 1; }

cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" --parallel "${SMOKETRACE_JOBS:-$(nproc)}" --target smoketrace_cli make_particle_scene >/dev/null
mkdir -p "$scenes"
[ -f "$scenes/tubes_${json_count}.json" ] || "$build/bench/make_particle_scene" "$json_count" "$scenes" json
[ -f "$scenes/tubes_${json_count}_exporter.json" ] ||
  "$build/bench/make_particle_scene" "$json_count" "$scenes" json-exporter
[ -f "$scenes/tubes_${ply_count}_ply.json" ] || "$build/bench/make_particle_scene" "$ply_count" "$scenes" ply

# measure NAME SCENE: one run of depths, its CSV to a file beside the scene.
measure() {
  local name="$1" scene="$2" log
  log="$(mktemp)"
  /usr/bin/time -v "$build/smoketrace" depths "$scene" -o "$scenes/$name.csv" --timings >"$log" 2>&1 ||
    { cat "$log" >&2; rm -f "$log"; exit 1; }
  local size
  size="$(du -h "$scene" | cut -f1) scene"
  [[ $name == ply* ]] && size+=", $(du -h "${scene%_ply.json}.ply" | cut -f1) PLY"
  echo "== $name ($size)"
  awk -F': ' '/Elapsed \(wall clock\)/ { n = split($2, t, ":")
                                          wall = t[n] + 60 * t[n - 1] + (n > 2 ? 3600 * t[1] : 0) }
              /Maximum resident set size/ { rss = $2 / 1024 }
              /User time \(seconds\)/ { user = $2 }
              /System time \(seconds\)/ { sys = $2 }
              /Minor \(reclaiming a frame\) page faults/ { minor = $2 }
              /Major \(requiring I\/O\) page faults/ { major = $2 }
              END { printf "wall            %.2f s\npeak RSS        %.0f MB\n", wall, rss
                    printf "user, system    %.2f s, %.2f s (system: %.0f %% of wall)\n", user, sys, 100 * sys / wall
                    printf "page faults     %d minor, %d major\n", minor, major }' "$log"
  printf '%-15s %8s %13s %10s\n' stage ms "minor faults" "system ms"
  local stage
  for stage in read_scene tlas_update od_pass resolve write_csv; do
    awk -F= -v s="$stage" '$1 == s { ms = $2 } $1 == s ".minor_faults" { f = $2 } $1 == s ".system_ms" { sys = $2 }
                           END { printf "%-15s %8.0f %13d %10.0f\n", s, ms, f, sys }' "$log"
  done
  rm -f "$log"
}
measure "json_${json_count}" "$scenes/tubes_${json_count}.json"
measure "json_exporter_${json_count}" "$scenes/tubes_${json_count}_exporter.json"
measure "ply_${ply_count}" "$scenes/tubes_${ply_count}_ply.json"
