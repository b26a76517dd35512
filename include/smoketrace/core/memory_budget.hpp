#pragma once
// How much memory this machine lets smoketrace use, and what the pipeline needs per particle and per hit,
// so that inputs too large for the machine are refused with a message instead of ending in std::bad_alloc
// or the kernel's out-of-memory killer (which, with overcommit, strikes long after the allocation).
#include <cstdint>
#include <string>

namespace smoketrace {

// Peak memory of `smoketrace render` per particle, rounded up: measured 1,133 B at 10^6 particles
// (assets/scenes/two_tubes_right.json with 10^6 tube particles, a 64x64 image, cutoff 1; /usr/bin/time's
// max RSS): the particle itself (40 B), its stand-in and billboard instances with double transforms, the
// billboard's two triangles kept in world space (72 B), the binary TLAS and its 4-wide copy (~85 B), and
// the per-particle arrays of the optical-depth pass and the view pass. `depths` needs about half of it
// (no billboards); reading a scene file peaks at about 530 B per particle (the JSON document), which is
// freed before the pipeline starts. Hit lists are not in it: they depend on the scene's density, see
// kPeakBytesPerStoredHit.
inline constexpr std::uint64_t kPeakBytesPerParticle = 1280;

// Peak memory per hit kept by the optical-depth pass, with room to spare: 4 B in its blocks and 8 B in the
// flat HitLists buffer gather() copies them into (kept at 24 so that the default budget stays where it was).
inline constexpr std::uint64_t kPeakBytesPerStoredHit = 24;

// Bytes of memory available to this process: the physical memory, or a cgroup limit (a container's
// memory.max / memory.limit_in_bytes) when that is lower. Read once; never 0.
[[nodiscard]] std::uint64_t machine_memory_bytes();

// "23.5 GiB", "512 MiB", "48 KiB", "100 bytes": for messages.
[[nodiscard]] std::string format_bytes(std::uint64_t bytes);

}  // namespace smoketrace
