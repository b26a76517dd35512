#pragma once
// What an any-hit callback answers, after the DXR any-hit shader (DirectX Raytracing spec, "any hit
// shader"): IgnoreHit(), returning normally (accept), or AcceptHitAndEndSearch().
#include <cstdint>

namespace smoketrace {

enum class AnyHitDecision : std::uint8_t {
    ignore,          // IgnoreHit(): the candidate is dropped, the search goes on with tmax unchanged
    accept,          // the candidate is committed, tmax shrinks to its t, the search goes on
    accept_and_end,  // AcceptHitAndEndSearch(): the candidate is committed and the search ends
};

}  // namespace smoketrace
