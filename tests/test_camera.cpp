// The pinhole camera (camera.hpp): pixel-centre rays exactly as they have always been computed, and rays
// through any point of the image in continuous pixel coordinates.
#include <smoketrace/render/camera.hpp>

#include <catch2/catch.hpp>

#include <glm/geometric.hpp>

#include <bit>
#include <cmath>
#include <cstdint>

using namespace smoketrace;

namespace {

struct CameraSetup {
    glm::vec3 position, look_at, up;
    float fov_deg;
    int width, height;
};

// Odd and even sizes, square and not, a tilted up vector, narrow and wide fields of view.
const CameraSetup kSetups[] = {
    {{0.0f, 2.0f, 10.0f}, {0.0f, 0.5f, 0.0f}, {0.0f, 1.0f, 0.0f}, 45.0f, 96, 96},
    {{-3.25f, 1.5f, 7.0f}, {0.2f, -0.4f, 0.1f}, {0.3f, 1.0f, -0.2f}, 32.0f, 37, 23},
    {{5.0f, -1.0f, -2.0f}, {0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 1.0f}, 120.0f, 20, 51},
};

// The pixel-centre ray as Camera computed it before ray_through() existed, redone from the camera's inputs:
// the frame in double (camera.cpp), then 2·(x + 0.5)/width − 1 in float. Every image the renderer writes at
// one sample per pixel rests on these bits, so they are compared exactly.
Ray reference_pixel_ray(const CameraSetup& c, int x, int y, float tmin) {
    const glm::dvec3 forward_d = glm::normalize(glm::dvec3(c.look_at) - glm::dvec3(c.position));
    const glm::dvec3 up_d = glm::dvec3(c.up) / glm::length(glm::dvec3(c.up));
    const glm::vec3 forward(forward_d);
    const glm::vec3 right(glm::normalize(glm::cross(forward_d, up_d)));
    const glm::vec3 up = glm::cross(right, forward);
    const float half_height = std::tan(0.5f * c.fov_deg * 3.14159265358979f / 180.0f);
    const float half_width = half_height * float(c.width) / float(c.height);
    const float sx = (2.0f * (float(x) + 0.5f) / float(c.width) - 1.0f) * half_width;
    const float sy = (1.0f - 2.0f * (float(y) + 0.5f) / float(c.height)) * half_height;
    return Ray{c.position, tmin, glm::normalize(forward + sx * right + sy * up), INFINITY};
}

bool same_bits(const Ray& a, const Ray& b) {
    const auto bits = [](float f) { return std::bit_cast<std::uint32_t>(f); };
    for (int k = 0; k < 3; ++k)
        if (bits(a.origin[k]) != bits(b.origin[k]) || bits(a.direction[k]) != bits(b.direction[k])) return false;
    return bits(a.tmin) == bits(b.tmin) && bits(a.tmax) == bits(b.tmax);
}

}  // namespace

TEST_CASE("camera: ray(x, y) and ray_through(x + 0.5, y + 0.5) are the pixel-centre ray, bit for bit", "[camera]") {
    for (const CameraSetup& c : kSetups) {
        const Camera camera(c.position, c.look_at, c.up, c.fov_deg, c.width, c.height);
        int differing = 0;
        for (int y = 0; y < c.height; ++y)
            for (int x = 0; x < c.width; ++x) {
                const Ray want = reference_pixel_ray(c, x, y, 1e-3f);
                if (!same_bits(camera.ray(x, y, 1e-3f), want)) ++differing;
                if (!same_bits(camera.ray_through(float(x) + 0.5f, float(y) + 0.5f, 1e-3f), want)) ++differing;
            }
        CAPTURE(c.width, c.height);
        CHECK(differing == 0);
    }
}

TEST_CASE("camera: ray_through takes continuous image coordinates, y down from the top-left corner", "[camera]") {
    // The camera {0, 0, 0} looking down −z with up +y: right is +x, so the image plane at distance 1 spans
    // x in [−hw, hw], y in [−hh, hh] with hh = tan(fov/2) and hw = hh·width/height. Directions agree with
    // the exact ones to a few float steps (5e-7 allows ~8 of them at unit length).
    const int width = 40, height = 30;
    const Camera camera({0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, -1.0f}, {0.0f, 1.0f, 0.0f}, 60.0f, width, height);
    const double hh = std::tan(30.0 * 3.14159265358979323846 / 180.0), hw = hh * width / height;
    struct Point {
        float image_x, image_y;
        glm::dvec3 direction;  // not normalised
    };
    const Point points[] = {
        {0.0f, 0.0f, {-hw, hh, -1.0}},                          // the top-left corner of pixel (0, 0)
        {float(width), float(height), {hw, -hh, -1.0}},         // the bottom-right corner of the image
        {float(width), 0.0f, {hw, hh, -1.0}},                   // the top-right corner
        {0.5f * width, 0.5f * height, {0.0, 0.0, -1.0}},        // the centre: straight ahead
        {10.25f, 22.75f, {(2.0 * 10.25 / width - 1.0) * hw, (1.0 - 2.0 * 22.75 / height) * hh, -1.0}},
    };
    for (const Point& p : points) {
        CAPTURE(p.image_x, p.image_y);
        const Ray r = camera.ray_through(p.image_x, p.image_y, 0.25f);
        const glm::dvec3 want = glm::normalize(p.direction);
        CHECK(r.origin == glm::vec3(0.0f));
        CHECK(r.tmin == 0.25f);
        CHECK(std::isinf(r.tmax));
        for (int k = 0; k < 3; ++k) CHECK(std::abs(double(r.direction[k]) - want[k]) < 5e-7);
    }
}
