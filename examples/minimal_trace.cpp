// The trace API in a few lines: a two-level scene (one sphere geometry, placed three times by instances),
// one ray through all three, and an any-hit callback that collects every surface the ray crosses.
#include <smoketrace/trace/trace.hpp>

#include <algorithm>
#include <cstdio>
#include <vector>

using namespace smoketrace;

int main() {
    AccelScene scene;
    const auto ball = scene.add_bottom_level(BottomLevel::from_spheres({Sphere{{0, 0, 0}, 1}}, /*opaque=*/false));
    for (double x : {0.0, 3.0, 6.0}) scene.add_instance({ball, AffineTransform::translate_scale({x, 0, 0}, 0.5)});
    scene.commit();

    std::vector<TraceHit> hits;  // non-opaque hits call any-hit; ignore each, so that the search goes on
    trace(scene, Ray{{-2, 0, 0}, 0.0f, {1, 0, 0}}, ray_flag_none, 0xFF, [&](const TraceHit& hit) {
        hits.push_back(hit);
        return AnyHitDecision::ignore;
    });
    std::sort(hits.begin(), hits.end(), [](auto& a, auto& b) { return a.t < b.t; });  // any-hit order is free
    for (const TraceHit& h : hits)
        std::printf("t=%.3f instance=%u %s\n", h.t, h.instance_index, h.front_face() ? "enter" : "leave");
}
