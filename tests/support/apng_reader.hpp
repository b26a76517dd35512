#pragma once
// An animated PNG taken apart by the APNG specification (https://wiki.mozilla.org/APNG_Specification),
// independently of src/io/png_io.cpp: chunk CRCs by zlib's crc32(), frame data by zlib's inflate and the
// PNG specification's five row filters. Every rule it checks that the file breaks throws
// std::runtime_error saying which (tests/test_png_io.cpp, test_cli.cpp).
#include <zlib.h>

#include <array>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace smoketrace::test {

struct ApngFrame {
    std::uint32_t width = 0, height = 0, x_offset = 0, y_offset = 0;
    std::uint16_t delay_num = 0, delay_den = 0;
    std::uint8_t dispose_op = 0, blend_op = 0;
    bool in_idat = false;           // the frame's data is the IDAT (the image a still viewer shows)
    std::vector<std::uint8_t> rgb;  // width·height·3, top row first
};

struct Apng {
    std::uint32_t width = 0, height = 0;
    std::uint32_t num_frames = 0, num_plays = 0;
    std::vector<ApngFrame> frames;
    std::vector<std::string> chunk_types;  // in file order
};

namespace apng_detail {

inline std::uint32_t be32(const std::uint8_t* p) {
    return (std::uint32_t(p[0]) << 24) | (std::uint32_t(p[1]) << 16) | (std::uint32_t(p[2]) << 8) | p[3];
}
inline std::uint16_t be16(const std::uint8_t* p) { return std::uint16_t((p[0] << 8) | p[1]); }

[[noreturn]] inline void fail(const std::string& what) { throw std::runtime_error("APNG: " + what); }

// The zlib stream of one frame back to its RGB rows: inflate, then undo each row's filter (PNG 9.2-9.4).
inline std::vector<std::uint8_t> decode_rgb(const std::vector<std::uint8_t>& stream, std::uint32_t width,
                                            std::uint32_t height) {
    const std::size_t stride = std::size_t(width) * 3;
    std::vector<std::uint8_t> filtered(std::size_t(height) * (stride + 1) + 1);  // +1: detects excess data
    uLongf size = uLongf(filtered.size());
    if (uncompress(filtered.data(), &size, stream.data(), uLong(stream.size())) != Z_OK)
        fail("a frame's zlib stream does not inflate (or inflates to more than its rows)");
    if (size != filtered.size() - 1) fail("a frame's zlib stream inflates to the wrong number of bytes");
    std::vector<std::uint8_t> rgb(std::size_t(height) * stride);
    for (std::size_t y = 0; y < height; ++y) {
        const std::uint8_t filter = filtered[y * (stride + 1)];
        const std::uint8_t* in = &filtered[y * (stride + 1) + 1];
        std::uint8_t* row = &rgb[y * stride];
        const std::uint8_t* up = y > 0 ? row - stride : nullptr;
        for (std::size_t i = 0; i < stride; ++i) {
            const int a = i >= 3 ? row[i - 3] : 0, b = up ? up[i] : 0, c = up && i >= 3 ? up[i - 3] : 0;
            int prediction = 0;
            switch (filter) {
                case 0: prediction = 0; break;
                case 1: prediction = a; break;
                case 2: prediction = b; break;
                case 3: prediction = (a + b) / 2; break;
                case 4: {
                    const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
                    prediction = pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
                    break;
                }
                default: fail("row filter type " + std::to_string(filter) + " is not one of 0-4");
            }
            row[i] = std::uint8_t(in[i] + prediction);
        }
    }
    return rgb;
}

}  // namespace apng_detail

// Parses `bytes` as an 8-bit RGB APNG and decodes every frame. Checks: the signature; every chunk complete
// and its CRC right; IHDR first; acTL once, before IDAT; each frame an fcTL followed by its data (IDAT for
// the first frame, fdAT for the others), inside the image; sequence numbers of fcTL and fdAT 0, 1, 2, …
// with no gap; as many fcTL as acTL's num_frames; IEND last with nothing after it.
inline Apng read_apng(const std::string& file) {
    using namespace apng_detail;
    const auto* bytes = reinterpret_cast<const std::uint8_t*>(file.data());
    static constexpr std::uint8_t kSignature[8] = {137, 80, 78, 71, 13, 10, 26, 10};
    if (file.size() < 8 || std::memcmp(bytes, kSignature, 8) != 0) fail("no PNG signature");
    Apng apng;
    std::size_t at = 8;
    std::uint32_t next_sequence = 0;
    bool have_actl = false, seen_idat = false, ended = false;
    std::vector<std::uint8_t> stream;  // the current frame's zlib stream
    const auto close_frame = [&] {
        if (apng.frames.empty()) return;
        ApngFrame& f = apng.frames.back();
        if (stream.empty()) fail("frame " + std::to_string(apng.frames.size() - 1) + " has no data");
        f.rgb = decode_rgb(stream, f.width, f.height);
        stream.clear();
    };
    while (!ended) {
        if (file.size() - at < 12) fail("truncated at byte " + std::to_string(at));
        const std::uint32_t length = be32(bytes + at);
        if (length > 0x7FFF'FFFFu || file.size() - at - 12 < length) fail("truncated chunk at byte " + std::to_string(at));
        const std::string type(file.data() + at + 4, 4);
        const std::uint8_t* data = bytes + at + 8;
        const std::uint32_t crc = std::uint32_t(crc32(crc32(0L, Z_NULL, 0), bytes + at + 4, uInt(length) + 4));
        if (crc != be32(data + length)) fail("CRC mismatch in chunk " + type + " at byte " + std::to_string(at));
        const bool first = apng.chunk_types.empty();
        apng.chunk_types.push_back(type);
        at += 12 + std::size_t(length);
        if (first != (type == "IHDR")) fail("IHDR is not the first chunk (or comes twice)");
        if (type == "IHDR") {
            if (length != 13) fail("IHDR is not 13 bytes");
            apng.width = be32(data);
            apng.height = be32(data + 4);
            if (data[8] != 8 || data[9] != 2 || data[10] != 0 || data[11] != 0 || data[12] != 0)
                fail("not 8-bit RGB, zlib, filter method 0, not interlaced");
        } else if (type == "acTL") {
            if (have_actl || seen_idat) fail("acTL twice or after IDAT");
            if (length != 8) fail("acTL is not 8 bytes");
            have_actl = true;
            apng.num_frames = be32(data);
            apng.num_plays = be32(data + 4);
            if (apng.num_frames == 0) fail("acTL announces 0 frames");
        } else if (type == "fcTL") {
            if (!have_actl) fail("fcTL before acTL");
            if (length != 26) fail("fcTL is not 26 bytes");
            if (be32(data) != next_sequence++) fail("fcTL sequence number out of order");
            close_frame();
            ApngFrame f;
            f.width = be32(data + 4);
            f.height = be32(data + 8);
            f.x_offset = be32(data + 12);
            f.y_offset = be32(data + 16);
            f.delay_num = be16(data + 20);
            f.delay_den = be16(data + 22);
            f.dispose_op = data[24];
            f.blend_op = data[25];
            if (f.width == 0 || f.height == 0 || std::uint64_t(f.x_offset) + f.width > apng.width ||
                std::uint64_t(f.y_offset) + f.height > apng.height)
                fail("fcTL's region is outside the image");
            if (f.dispose_op > 2 || f.blend_op > 1) fail("fcTL's dispose_op or blend_op is invalid");
            if (apng.frames.empty() && (f.x_offset || f.y_offset || f.width != apng.width || f.height != apng.height))
                fail("the first frame does not cover the image");
            apng.frames.push_back(f);
        } else if (type == "IDAT") {
            if (!have_actl) fail("IDAT before acTL");
            if (apng.frames.size() != 1 || (seen_idat && apng.chunk_types.end()[-2] != "IDAT"))
                fail("IDAT that is not the first frame's data, or IDAT chunks not together");
            seen_idat = true;
            apng.frames.back().in_idat = true;
            stream.insert(stream.end(), data, data + length);
        } else if (type == "fdAT") {
            if (length < 4) fail("fdAT shorter than its sequence number");
            if (be32(data) != next_sequence++) fail("fdAT sequence number out of order");
            if (apng.frames.size() < 2 || !seen_idat) fail("fdAT before the second frame's fcTL");
            stream.insert(stream.end(), data + 4, data + length);
        } else if (type == "IEND") {
            if (length != 0) fail("IEND has data");
            close_frame();
            ended = true;
        } else if (!(type[0] & 0x20)) {
            fail("unknown critical chunk " + type);
        }
    }
    if (at != file.size()) fail("bytes after IEND");
    if (!seen_idat) fail("no IDAT");
    if (apng.frames.size() != apng.num_frames)
        fail("acTL announces " + std::to_string(apng.num_frames) + " frames, the file has " +
             std::to_string(apng.frames.size()));
    return apng;
}

}  // namespace smoketrace::test
