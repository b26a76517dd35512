#include <smoketrace/smoke/particle_groups.hpp>

#include <stdexcept>

namespace smoketrace {

std::vector<std::uint32_t> particle_group(std::size_t n, std::uint32_t groups, std::uint64_t frame) {
    if (groups == 0) throw std::invalid_argument("particle_group: groups must be >= 1");
    std::vector<std::uint32_t> ids;
    ids.reserve(n / groups + 1);
    for (std::size_t i = static_cast<std::size_t>(frame % groups); i < n; i += groups)
        ids.push_back(static_cast<std::uint32_t>(i));
    return ids;
}

}  // namespace smoketrace
