#include <smoketrace/accel/instance.hpp>

#include <glm/matrix.hpp>
#include <cmath>
#include <stdexcept>

namespace smoketrace {

double AffineTransform::determinant() const { return glm::determinant(linear); }

void AffineTransform::check_invertible() const {
    const double det = determinant();
    if (!(std::abs(det) > 0.0) || !std::isfinite(det)) throw std::domain_error("AffineTransform: singular transform");
}

AffineTransform AffineTransform::inverse() const {
    check_invertible();
    AffineTransform inv;
    inv.linear = glm::inverse(linear);
    inv.translation = -(inv.linear * translation);
    return inv;
}

AffineTransform AffineTransform::translate_scale(const glm::dvec3& t, double s) {
    AffineTransform m;
    m.linear = glm::dmat3(s);
    m.translation = t;
    return m;
}

}  // namespace smoketrace
