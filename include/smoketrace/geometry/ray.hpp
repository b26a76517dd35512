#pragma once
// A ray: origin + t·direction for t in [tmin, tmax]. The direction need not be unit length; every
// distance in smoketrace is a ray parameter t, which instance transforms preserve (see instance.hpp).
#include <glm/vec3.hpp>
#include <limits>

namespace smoketrace {

struct Ray {
    glm::vec3 origin{0.0f};
    float tmin = 0.0f;
    glm::vec3 direction{0.0f, 0.0f, 1.0f};
    float tmax = std::numeric_limits<float>::infinity();
};

}  // namespace smoketrace
