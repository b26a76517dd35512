#!/usr/bin/env bash
# Plots of a benchmark run: PNGs from the CSVs that smoketrace_bench wrote, made with gnuplot
# (Debian package gnuplot-nox, installed by scripts/setup.sh).
#
#   scripts/plot.sh [--assets] [RESULTS_DIR]
#
# RESULTS_DIR defaults to bench-results (smoketrace_bench's --results default). The plots go to
# RESULTS_DIR/plots/:
#   pareto.png    run time against error, one point per configuration, the Pareto fronts marked
#                 (error_sweeps.csv, section "error")
#   groups.png    image error frame by frame for 1…32 particle groups (error_frames.csv)
#   stages.png    stage times against particle count, all threads, and the total on one thread
#                 (scaling.csv, section "scaling"; the lines break between the table B.1 counts and
#                 the large counts, whose scenes differ: radius shrunk, no cutoff)
#   resolver.png  resolver time per hit against the cutoff for bubble, std::sort and the adaptive sort
#                 (resolver.csv, section "resolver", thesis table B.4)
#   embree.png    time ours / time Embree 3 for each side-by-side measurement (summary.txt)
#   threads.png   the thread sweep: speedup over one thread, ours and Embree's fastest, and time ours / time
#                 Embree at each thread count, one line per workload (threads.csv, section "threads")
#   grid.png      the reference render, the thesis's configuration, the best configuration and the
#                 best one's error heat map (images/, section "error")
#   truth_pareto.png  run time against image error against the ground truth, one panel per scene, the
#                 Pareto front marked (truth_sweeps.csv, section "truth")
#   truth_grid.png    per scene: the truth, the scene's settings, the thesis's settings and the error heat
#                 map of the scene's settings (images/truth_*, section "truth")
# A plot whose input is missing (its section was not run) is skipped with a note.
# --assets also copies the plots docs/performance.md and docs/accuracy.md show into assets/plots/.
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
assets=0
results=""
for a in "$@"; do
  case "$a" in
    --assets) assets=1 ;;
    -h|--help) sed -n '2,27p' "$0"; exit 0 ;;
    *) results="$a" ;;
  esac
done
results="${results:-bench-results}"
[ -d "$results" ] || { echo "plot: no results folder '$results' (run smoketrace_bench first)" >&2; exit 1; }
command -v gnuplot >/dev/null || { echo "plot: gnuplot not found (scripts/setup.sh installs gnuplot-nox)" >&2; exit 1; }
out="$results/plots"
mkdir -p "$out"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

# Columns of a CSV by header name, for the rows whose column $2 equals $3 (empty $2: every row);
# whitespace separated.
pick() {
  local file="$1" key="$2" want="$3"
  shift 3
  awk -F, -v key="$key" -v want="$want" -v cols="$*" '
    NR == 1 { for (i = 1; i <= NF; i++) h[$i] = i; n = split(cols, c, " "); next }
    key == "" || $h[key] == want {
      line = ""
      for (k = 1; k <= n; k++) line = line (k > 1 ? " " : "") $h[c[k]]
      print line
    }' "$file"
}

have() {
  if [ -f "$results/$1" ]; then return 0; fi
  echo "plot: skipping $2 ($results/$1 missing)"
  return 1
}

common='set terminal pngcairo size 1400,650 font "sans,11" noenhanced
set datafile separator ","
set datafile columnheaders
set grid lc rgb "#dddddd"
set key top right box opaque'

made=()

# ---- run time against error ------------------------------------------------------------------------
if have error_sweeps.csv "pareto.png"; then
  # An error of exactly 0 (the reference, and whatever matches it bit for bit) cannot sit on a log
  # axis: it is drawn at the floor, the axis' left edge, labelled "exact".
  { echo "error,ms"; pick "$results/error_sweeps.csv" pareto 1 image_rmse total_median |
      awk '{ e = $1 < 1e-5 ? 1e-5 : $1; print e "," $2 }' | sort -g; } > "$tmp/front_image.csv"
  { echo "error,ms"; pick "$results/error_sweeps.csv" pareto_depth 1 transmittance_err_mean depth_median |
      awk '{ e = $1 < 1e-6 ? 1e-6 : $1; print e "," $2 }' | sort -g; } > "$tmp/front_depth.csv"
  gnuplot <<EOF
$common
set output "$out/pareto.png"
f = "$results/error_sweeps.csv"
sweeps = "reference shape cutoff groups threshold compositing combined"
colors = "#000000 #1f77b4 #ff7f0e #2ca02c #9467bd #d62728 #8c564b"
floor_i = 1e-5
floor_d = 1e-6
fl(x, lo) = x < lo ? lo : x
set multiplot layout 1,2 title "Run time against error (750 particles, frame 32 vs the exact reference; medians over frames 1-32)"
set logscale x
set format x "%g"
set key top left maxrows 4 box opaque font "sans,10"
set offsets graph 0, graph 0, graph 0.35, graph 0
set xlabel "image RMSE (linear RGB; exact = 1e-5)"
set ylabel "frame time, median ms"
set title "whole frame: total time vs image error\n(grey: the Pareto front)"
plot "$tmp/front_image.csv" using 1:2 with steps lw 3 lc rgb "#bbbbbb" title "Pareto front", \
     for [i = 1:words(sweeps)] f using (strcol("sweep") eq word(sweeps, i) ? fl(column("image_rmse"), floor_i) : NaN):(column("total_median")) \
       with points pt 7 ps 1.3 lc rgb word(colors, i) title word(sweeps, i), \
     f using (fl(column("image_rmse"), floor_i)):(column("total_median")):(strcol("value")) \
       with labels offset 0.6,0.6 left font "sans,8" notitle
set xlabel "mean |T - T_ref| over particles (transmittance toward the light; exact = 1e-6)"
set ylabel "optical-depth time (od_pass + resolve), median ms"
set title "optical depths: od_pass + resolve vs depth error\n(threshold and eq. 4.1 leave the depths exact: not shown)"
set logscale y
set format y "%g"
set offsets 0, 0, 0, 0
set key bottom left maxrows 3
depth_sweeps = "reference shape cutoff groups combined"
depth_colors = "#000000 #1f77b4 #ff7f0e #2ca02c #8c564b"
plot "$tmp/front_depth.csv" using 1:2 with steps lw 3 lc rgb "#bbbbbb" title "Pareto front", \
     for [i = 1:words(depth_sweeps)] f using (strcol("sweep") eq word(depth_sweeps, i) ? fl(column("transmittance_err_mean"), floor_d) : NaN):(column("depth_median")) \
       with points pt 7 ps 1.3 lc rgb word(depth_colors, i) title word(depth_sweeps, i), \
     f using (strcol("sweep") eq "threshold" || strcol("sweep") eq "compositing" ? NaN : fl(column("transmittance_err_mean"), floor_d)):(column("depth_median")):(strcol("value")) \
       with labels offset 0.6,0.6 left font "sans,8" notitle
unset multiplot
EOF
  made+=(pareto.png)
fi

# ---- stale optical depths, frame by frame -------------------------------------------------------------
if have error_frames.csv "groups.png"; then
  for g in 2 4 8 16 32; do
    pick "$results/error_frames.csv" config "groups_$g" frame image_rmse > "$tmp/groups_$g.dat"
  done
  gnuplot <<EOF
$common
set datafile separator whitespace
set datafile nocolumnheaders
set terminal pngcairo size 900,550 font "sans,11" noenhanced
set output "$out/groups.png"
set title "Particle groups: image RMSE against the reference, frame by frame (light turning 1 deg/frame)"
set xlabel "frame"
set ylabel "image RMSE (linear RGB)"
set key top left
plot for [g in "2 4 8 16 32"] "$tmp/groups_".g.".dat" using 1:2 with linespoints pt 7 ps 0.6 title g." groups"
EOF
  made+=(groups.png)
fi

# ---- stage times against particle count ---------------------------------------------------------------
if have scaling.csv "stages.png"; then
  threads=$(pick "$results/scaling.csv" "" "" threads | sort -n | tail -1)
  size=$(pick "$results/scaling.csv" "" "" size | head -1)
  # A blank line where the large counts start: gnuplot breaks the lines there.
  split_large() { awk '$1 >= 10000 && prev < 10000 && NR > 1 { print "" } { print; prev = $1 }'; }
  pick "$results/scaling.csv" threads "$threads" particles tlas_update_median od_pass_median resolve_median \
    view_median total_median | split_large > "$tmp/stages_all.dat"
  pick "$results/scaling.csv" threads 1 particles total_median | split_large > "$tmp/stages_one.dat"
  gnuplot <<EOF
$common
set datafile separator whitespace
set datafile nocolumnheaders
set terminal pngcairo size 900,600 font "sans,11" noenhanced
set output "$out/stages.png"
set title "Stage times against particle count (whole frame, ${size}x${size}, sphere stand-ins)\n250-1500: cutoff 60, radius 0.35; 10k, 100k: no cutoff, radius 0.35*sqrt(750/N)"
set logscale xy
set format x "%g"; set format y "%g"
set xlabel "particles"
set ylabel "median ms per frame"
set key top left
stages = "tlas_update od_pass resolve view total"
plot for [i = 1:5] "$tmp/stages_all.dat" using 1:(column(i + 1)) with linespoints pt 7 lw 2 \
       title word(stages, i)." ($threads threads)", \
     "$tmp/stages_one.dat" using 1:2 with linespoints dt 2 pt 6 lw 2 lc rgb "black" title "total (1 thread)"
EOF
  made+=(stages.png)
fi

# ---- resolver against the cutoff ----------------------------------------------------------------------
if have resolver.csv "resolver.png"; then
  for m in bubble std_sort adaptive; do
    pick "$results/resolver.csv" table b4 threads method items_per_list ns_per_item |
      awk -v m="$m" '$1 == 1 && $2 == m { print $3, $4 }' > "$tmp/resolver_$m.dat"
  done
  gnuplot <<EOF
$common
set datafile separator whitespace
set datafile nocolumnheaders
set terminal pngcairo size 900,600 font "sans,11" noenhanced
set output "$out/resolver.png"
set title "Hit resolver: time per hit against the cutoff (750 particles, k hits each, 1 thread; thesis table B.4)"
set logscale y
set format y "%g"
set xlabel "hits per particle (cutoff k)"
set ylabel "ns per hit"
set key top left
plot for [m in "bubble std_sort adaptive"] "$tmp/resolver_".m.".dat" using 1:2 with linespoints pt 7 lw 2 title m
EOF
  made+=(resolver.png)
fi

# ---- ours against Embree ------------------------------------------------------------------------------
if have summary.txt "embree.png"; then
  # Every bar is time ours / time Embree over the same work (the rays/s ratios of section bvh are
  # inverted to match).
  awk -F= '
    $1 == "build_ratio_vs_embree_medium_1t"  { print "\"BLAS build\\n(medium)\\n1 thread\"", $2 }
    $1 == "build_ratio_vs_embree_medium_2t"  { print "\"BLAS build\\n(medium)\\n2 threads\"", $2 }
    $1 == "smoke_build_ratio_vs_embree"      { print "\"scene build\\n(billboards)\"", $2 }
    $1 == "closest_hit_ratio_vs_embree"      { print "\"closest hit\\n(mesh)\"", 1 / $2 }
    $1 == "all_hits_ratio_vs_embree"         { print "\"all hits\\n(mesh)\"", 1 / $2 }
    $1 == "od_sphere_ratio_vs_embree_sphere" { print "\"optical-depth\\npass\\n(spheres)\"", $2 }
    $1 == "od_pass_ratio_vs_embree"          { print "\"optical-depth\\npass\\n(icosahedra)\"", $2 }
    $1 == "view_rays_ratio_vs_embree"        { print "\"view rays\\n(closest)\"", $2 }
    $1 == "view_layers_ratio_vs_embree"      { print "\"view rays\\n(all layers)\"", $2 }
  ' "$results/summary.txt" > "$tmp/embree.dat"
  if [ -s "$tmp/embree.dat" ]; then
    gnuplot <<EOF
$common
set datafile separator whitespace
set datafile nocolumnheaders
set terminal pngcairo size 1300,560 font "sans,11"
set output "$out/embree.png"
set title "smoketrace against Embree 3 (fastest Embree configuration, packets included), same run: time ours / time Embree"
set bmargin 5
set style fill solid 0.7 border -1
set boxwidth 0.6
set yrange [0:*]
set offsets 0, 0, graph 0.1, 0
set ylabel "time ours / time Embree  (1 = as fast, above 1 = slower)"
unset key
set arrow from graph 0, first 1 to graph 1, first 1 nohead dt 2 lw 2 lc rgb "black"
plot "$tmp/embree.dat" using 0:2:xtic(1) with boxes lc rgb "#4477aa", \
     "" using 0:2:(sprintf("%.2f", \$2)) with labels offset 0,0.8 notitle
EOF
    made+=(embree.png)
  fi
fi

# ---- the thread sweep ---------------------------------------------------------------------------------
if have threads.csv "threads.png"; then
  workloads=$(pick "$results/threads.csv" "" "" workload | awk '!seen[$0]++' | tr '\n' ' ')
  compared=""; alone=""
  for w in $workloads; do
    pick "$results/threads.csv" workload "$w" threads ours_speedup embree_speedup ratio_vs_embree > "$tmp/threads_$w.dat"
    # The frames have no Embree side (their rows leave its columns empty): ours alone, drawn in black.
    if awk 'NF == 4 { found = 1 } END { exit !found }' "$tmp/threads_$w.dat"; then compared+="$w "; else alone+="$w "; fi
  done
  cores=$(pick "$results/threads.csv" "" "" threads | sort -n | tail -1)
  gnuplot <<EOF
$common
set datafile separator whitespace
set datafile nocolumnheaders
set terminal pngcairo size 1800,820 font "sans,11" noenhanced
set output "$out/threads.png"
set multiplot layout 1,3 title "Thread sweep (section threads) against the thread count (x axis): medians of interleaved rounds, each contender in a TBB arena of the count"
set logscale xy 2
set format y "%g"
set xrange [1:$cores]
set key below maxcols 3 font "sans,9" box
compared = "$compared"
alone = "$alone"
colors = "#1f77b4 #ff7f0e #2ca02c #d62728 #9467bd #8c564b #e377c2 #7f7f7f #bcbd22 #17becf #393b79 #637939 #8c6d31 #843c39"
c(i) = word(colors, (i - 1) % words(colors) + 1)
set title "ours: speedup over 1 thread"
set ylabel "time at 1 thread / time at n"
plot x with lines dt 2 lc rgb "black" title "linear", \
     for [i = 1:words(alone)] "$tmp/threads_".word(alone, i).".dat" using 1:2 with linespoints pt 5 lw 3 lc rgb "black" dt i title word(alone, i), \
     for [i = 1:words(compared)] "$tmp/threads_".word(compared, i).".dat" using 1:2 with linespoints pt (i % 13 + 1) lw 2 lc rgb c(i) title word(compared, i)
set title "Embree's fastest contender: speedup over 1 thread"
plot x with lines dt 2 lc rgb "black" title "linear", \
     for [i = 1:words(compared)] "$tmp/threads_".word(compared, i).".dat" using 1:3 with linespoints pt (i % 13 + 1) lw 2 lc rgb c(i) title word(compared, i)
set title "time ours / time Embree's fastest (below 1: ours faster)"
set ylabel "ratio"
set logscale y 10
plot 1 with lines dt 2 lc rgb "black" notitle, \
     for [i = 1:words(compared)] "$tmp/threads_".word(compared, i).".dat" using 1:4 with linespoints pt (i % 13 + 1) lw 2 lc rgb c(i) title word(compared, i)
unset multiplot
EOF
  made+=(threads.png)
fi

# ---- image grid ---------------------------------------------------------------------------------------
if have images/grid.txt "grid.png"; then
  g="$results/images/grid.txt"
  val() { awk -v k="$1" -v f="$2" '$1 == k { print $f }' "$g"; }
  rest() { awk -v k="$1" '$1 == k { $1 = $2 = $3 = $4 = ""; sub(/^ +/, ""); print }' "$g"; }
  size=$(val size 2); frame=$(val frame 2)
  ref=$(val reference 2); ref_ms=$(val reference_ms 2)
  thesis=$(val thesis 2); thesis_db=$(val thesis 3); thesis_ms=$(val thesis 4)
  best=$(val best 2); best_db=$(val best 3); best_ms=$(val best 4); best_desc=$(rest best)
  thesis_desc=$(rest thesis)
  gnuplot <<EOF
set terminal pngcairo size 1600,470 font "sans,11" noenhanced
set output "$out/grid.png"
set multiplot layout 1,4 title "Frame $frame, ${size}x${size}: reference, the thesis's configuration, the best configuration and its error" font "sans,13"
unset key; unset tics; unset border
set size ratio -1
set lmargin 1; set rmargin 1
set title "reference: exact spheres, no cutoff, groups 1\n$ref_ms ms"
plot "$results/images/$ref.png" binary filetype=png with rgbimage
set title "thesis: $thesis_desc\nPSNR $thesis_db dB, $thesis_ms ms"
plot "$results/images/$thesis.png" binary filetype=png with rgbimage
set title "best: $best_desc\nPSNR $best_db dB, $best_ms ms"
plot "$results/images/$best.png" binary filetype=png with rgbimage
set title "error of best: per-pixel RMS (linear)"
set palette defined (0 "black", 1 "#5c1a8a", 2 "#d6456c", 3 "#fca50a", 4 "#fcffa4")
set colorbox vertical user origin 0.955,0.15 size 0.012,0.6
set cbtics font "sans,9"
set rmargin 6
plot "$results/images/heat_best.f32" binary array=(${size},${size}) format="%float" flipy with image
unset multiplot
EOF
  made+=(grid.png)
fi

# ---- run time against error, against the ground truth ---------------------------------------------------
if have truth_sweeps.csv "truth_pareto.png"; then
  scenes=$(pick "$results/truth_sweeps.csv" "" "" scene | awk '!seen[$0]++' | tr '\n' ' ')
  size=$(pick "$results/truth_sweeps.csv" "" "" size | head -1)
  panels=""
  for sc in $scenes; do
    { echo "error,ms"; pick "$results/truth_sweeps.csv" scene "$sc" pareto image_rmse total_median |
        awk '$1 == 1 { print $2 "," $3 }' | sort -g; } > "$tmp/truth_front_$sc.csv"
    { head -1 "$results/truth_sweeps.csv"; awk -F, -v sc="$sc" 'NR > 1 && $1 == sc' "$results/truth_sweeps.csv"; } \
      > "$tmp/truth_$sc.csv"
    # The row drawn with the true optical depths has no time of its own (repeats 0): not drawn.
    panels+="set title \"$sc (grey: the Pareto front)\"
plot \"$tmp/truth_front_$sc.csv\" using 1:2 with steps lw 3 lc rgb \"#bbbbbb\" title \"Pareto front\", \\
     for [i = 1:words(sweeps)] \"$tmp/truth_$sc.csv\" using (strcol(\"sweep\") eq word(sweeps, i) && column(\"repeats\") > 0 ? column(\"image_rmse\") : NaN):(column(\"total_median\")) with points pt 7 ps 1.2 lc rgb word(colors, i) title word(sweeps, i), \\
     \"$tmp/truth_$sc.csv\" using (column(\"repeats\") > 0 ? column(\"image_rmse\") : NaN):(column(\"total_median\")):(strcol(\"value\")) with labels offset 0.5,0.5 left font \"sans,7\" notitle
"
  done
  gnuplot <<EOF
$common
set terminal pngcairo size 1800,820 font "sans,11" noenhanced
set output "$out/truth_pareto.png"
sweeps = "scene mode shape cutoff groups spp compositing threshold named"
colors = "#000000 #e377c2 #1f77b4 #ff7f0e #2ca02c #17becf #d62728 #9467bd #8c564b"
set multiplot layout 1,$(echo $scenes | wc -w) title "Run time against error against the ground truth (${size}x${size}; frame time: median of interleaved repeats)"
set logscale xy
set format x "%g"; set format y "%g"
set xlabel "image RMSE against the truth (linear RGB)"
set ylabel "frame time, median ms"
set key top right maxrows 5 box opaque font "sans,9"
$panels
unset multiplot
EOF
  made+=(truth_pareto.png)
fi

if have images/truth_grid.txt "truth_grid.png"; then
  g="$results/images/truth_grid.txt"
  size=$(awk '$1 == "size" { print $2 }' "$g")
  scenes=$(awk '$2 == "truth" { print $1 }' "$g" | tr '\n' ' ')
  field() { awk -v s="$1" -v r="$2" -v f="$3" '$1 == s && $2 == r { print $f }' "$g"; }
  n=$(echo $scenes | wc -w)
  rows=""
  for sc in $scenes; do
    t=$(field "$sc" truth 3)
    rows+="set title \"$sc: the truth ($(field "$sc" truth 4) s)\"
plot \"$results/images/$t.png\" binary filetype=png with rgbimage
set title \"the scene's settings\\nPSNR $(field "$sc" scene 4) dB, $(field "$sc" scene 5) ms\"
plot \"$results/images/${t}_$(field "$sc" scene 3).png\" binary filetype=png with rgbimage
set title \"the thesis's settings\\nPSNR $(field "$sc" thesis 4) dB, $(field "$sc" thesis 5) ms\"
plot \"$results/images/${t}_$(field "$sc" thesis 3).png\" binary filetype=png with rgbimage
set title \"error of the scene's settings\\n(per-pixel RMS, linear)\"
plot \"$results/images/truth_heat_${sc}_$(field "$sc" scene 3).f32\" binary array=(${size},${size}) format=\"%float\" flipy with image
"
  done
  gnuplot <<EOF
set terminal pngcairo size 1600,$((400 * n + 40)) font "sans,11" noenhanced
set output "$out/truth_grid.png"
set multiplot layout $n,4 title "The ground truth, the scene's settings, the thesis's settings and the error of the scene's (${size}x${size})" font "sans,13"
unset key; unset tics; unset border
set size ratio -1
set lmargin 1; set rmargin 1
set palette defined (0 "black", 1 "#5c1a8a", 2 "#d6456c", 3 "#fca50a", 4 "#fcffa4")
set cbtics font "sans,9"
$rows
unset multiplot
EOF
  made+=(truth_grid.png)
fi

echo "plot: wrote ${made[*]/#/$out/}"

if [ "$assets" = 1 ]; then
  mkdir -p "$root/assets/plots"
  for p in pareto.png grid.png stages.png resolver.png embree.png groups.png truth_pareto.png truth_grid.png; do
    [ -f "$out/$p" ] && cp "$out/$p" "$root/assets/plots/$p"
  done
  echo "plot: copied the README's plots to $root/assets/plots/"
fi
