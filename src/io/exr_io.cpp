// OpenEXR files in and out (see exr_io.hpp).
#include <smoketrace/io/exr_io.hpp>

#include <smoketrace/io/file_bytes.hpp>
#include <smoketrace/io/output_path.hpp>

#include "float_image_rules.hpp"

#include <IexBaseExc.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <optional>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

namespace smoketrace {

namespace fs = std::filesystem;

using float_image::check_writable;
using float_image::pixel_name;
using float_image::read_error;
using float_image::write_error;

namespace {

// The largest file read: the largest image as four uncompressed float channels, and room for the header
// and the offset table. A compressed file of a permitted size is far smaller.
constexpr std::uint64_t kMaxExrFileBytes = kMaxImagePixels * 16 + (std::uint64_t(1) << 24);

// An EXR file's bytes in memory, grown as OpenEXR writes them. OpenEXR seeks back to fill in the offset
// table once the pixels are written, so a stream that cannot seek (a pipe, standard output) cannot take the
// file directly: it is written whole once complete.
class MemoryOutput final : public Imf::OStream {
public:
    MemoryOutput(const char* name, std::string& bytes) : Imf::OStream(name), bytes_(bytes) {}
    void write(const char c[], int n) override {
        const std::size_t end = std::size_t(at_) + std::size_t(n);
        if (end > bytes_.size()) bytes_.resize(end);
        std::memcpy(bytes_.data() + at_, c, std::size_t(n));
        at_ = end;
    }
    std::uint64_t tellp() override { return at_; }
    void seekp(std::uint64_t pos) override { at_ = pos; }

private:
    std::string& bytes_;
    std::uint64_t at_ = 0;
};

// A whole EXR file in memory, read by OpenEXR. A read past the end throws, as OpenEXR's own file stream does.
class MemoryInput final : public Imf::IStream {
public:
    MemoryInput(const char* name, const std::vector<std::uint8_t>& bytes) : Imf::IStream(name), bytes_(bytes) {}
    bool read(char c[], int n) override {
        if (n < 0 || at_ > bytes_.size() || bytes_.size() - at_ < std::uint64_t(n))
            throw Iex::InputExc("the file ends before the data it announces");
        std::memcpy(c, bytes_.data() + at_, std::size_t(n));
        at_ += std::uint64_t(n);
        return at_ < bytes_.size();
    }
    std::uint64_t tellg() override { return at_; }
    void seekg(std::uint64_t pos) override { at_ = pos; }

private:
    const std::vector<std::uint8_t>& bytes_;
    std::uint64_t at_ = 0;
};

std::int32_t read_le32(const std::uint8_t* p) {
    return std::int32_t(std::uint32_t(p[0]) | (std::uint32_t(p[1]) << 8) | (std::uint32_t(p[2]) << 16) |
                        (std::uint32_t(p[3]) << 24));
}

// Checks what OpenEXR would otherwise allocate for before reading a pixel: the magic number, one part of
// flat pixels, and the data window's size, read from the header's attribute list (OpenEXR file layout:
// magic, version and flags, then attributes "name\0type\0" size value, ended by an empty name).
void check_exr_header(const fs::path& path, const std::vector<std::uint8_t>& bytes) {
    static constexpr std::uint8_t kMagic[4] = {0x76, 0x2F, 0x31, 0x01};
    if (bytes.size() < 8 || std::memcmp(bytes.data(), kMagic, 4) != 0)
        read_error(path, "not an OpenEXR file (the EXR magic number is missing)");
    const std::uint32_t flags = std::uint32_t(read_le32(&bytes[4]));
    if (flags & 0x1000u) read_error(path, "a multi-part OpenEXR file: one part of RGB pixels is expected");
    if (flags & 0x800u) read_error(path, "a deep OpenEXR file: flat RGB pixels are expected");
    std::size_t at = 8;
    const auto text = [&](const char* what) {
        const auto* begin = bytes.data() + at;
        const auto* end = std::find(begin, bytes.data() + bytes.size(), std::uint8_t(0));
        if (end == bytes.data() + bytes.size()) read_error(path, std::string("truncated OpenEXR header: ") + what);
        at += std::size_t(end - begin) + 1;
        return std::string(reinterpret_cast<const char*>(begin), std::size_t(end - begin));
    };
    while (true) {
        const std::string name = text("an attribute name is cut off");
        if (name.empty()) break;
        const std::string type = text("an attribute type is cut off");
        if (bytes.size() - at < 4) read_error(path, "truncated OpenEXR header: attribute '" + name + "' is cut off");
        const std::int32_t size = read_le32(&bytes[at]);
        at += 4;
        if (size < 0 || bytes.size() - at < std::size_t(size))
            read_error(path, "truncated OpenEXR header: attribute '" + name + "' is cut off");
        if (name == "dataWindow") {
            if (type != "box2i" || size != 16) read_error(path, "corrupt OpenEXR header: dataWindow is not a box2i");
            const std::int64_t width = std::int64_t(read_le32(&bytes[at + 8])) - read_le32(&bytes[at]) + 1;
            const std::int64_t height = std::int64_t(read_le32(&bytes[at + 12])) - read_le32(&bytes[at + 4]) + 1;
            const std::string size_text = std::to_string(width) + "x" + std::to_string(height);
            if (width < 1 || height < 1 || width > kMaxImageSide || height > kMaxImageSide)
                read_error(path, "EXR size " + size_text + " is outside [1, " + std::to_string(kMaxImageSide) + "]");
            if (std::uint64_t(width) * std::uint64_t(height) > kMaxImagePixels)
                read_error(path, "EXR size " + size_text + " is more than " + std::to_string(kMaxImagePixels) +
                                     " pixels");
            return;
        }
        at += std::size_t(size);
    }
    read_error(path, "corrupt OpenEXR header: no dataWindow");
}

}  // namespace

void write_exr(const fs::path& path, const ImageRgba& image) {
    check_writable(path, image, "an EXR");
    std::string bytes;
    try {
        Imf::Header header(image.width, image.height);
        header.compression() = Imf::ZIP_COMPRESSION;
        const char* const names[3] = {"R", "G", "B"};
        Imf::FrameBuffer frame;
        // OpenEXR only reads the pixels it writes; its Slice takes a non-const pointer for both directions.
        char* const base = const_cast<char*>(reinterpret_cast<const char*>(image.pixels.data()));
        for (int c = 0; c < 3; ++c) {
            header.channels().insert(names[c], Imf::Channel(Imf::FLOAT));
            frame.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), sizeof(glm::vec4),
                                              sizeof(glm::vec4) * std::size_t(image.width)));
        }
        MemoryOutput out(path.c_str(), bytes);
        // One thread: OpenEXR's compression threads would make no other bytes, but the library's threads are
        // TBB's, and the frame is already rendered.
        Imf::OutputFile file(out, header, 0);
        file.setFrameBuffer(frame);
        file.writePixels(image.height);
    } catch (const Iex::BaseExc& e) {
        write_error(path, std::string("OpenEXR could not encode the image: ") + e.what());
    }
    write_output(path, [&](std::ostream& out) { out.write(bytes.data(), std::streamsize(bytes.size())); });
}

ImageRgba read_exr(const fs::path& path) {
    const std::vector<std::uint8_t> bytes = read_file_bytes(path, kMaxExrFileBytes);
    check_exr_header(path, bytes);
    std::optional<std::string> problem;
    ImageRgba image;
    try {
        MemoryInput in(path.c_str(), bytes);
        Imf::InputFile file(in, 0);
        const Imath::Box2i window = file.header().dataWindow();
        const Imf::ChannelList& channels = file.header().channels();
        for (const char* name : {"R", "G", "B"})
            if (channels.findChannel(name) == nullptr) {
                problem = std::string("the OpenEXR file has no ") + name + " channel (R, G and B are read)";
                break;
            }
        if (!problem && !file.isComplete()) problem = "truncated OpenEXR file: pixels are missing";
        if (!problem) {
            image = ImageRgba(window.max.x - window.min.x + 1, window.max.y - window.min.y + 1,
                              ImageRgba::Uninitialized{});
            Imf::FrameBuffer frame;
            const char* const names[4] = {"R", "G", "B", "A"};
            for (int c = 0; c < 4; ++c)
                frame.insert(names[c], Imf::Slice::Make(Imf::FLOAT, &image.pixels[0][c], window, sizeof(glm::vec4),
                                                        sizeof(glm::vec4) * std::size_t(image.width), 1, 1,
                                                        /*fillValue=*/1.0));
            file.setFrameBuffer(frame);
            file.readPixels(window.min.y, window.max.y);
        }
    } catch (const Iex::BaseExc& e) {
        problem = std::string("OpenEXR cannot read it: ") + e.what();
    }
    if (problem) read_error(path, *problem);
    const std::size_t width = std::size_t(image.width);
    for (std::size_t i = 0; i < image.pixels.size(); ++i) {
        const glm::vec4 p = image.pixels[i];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || !std::isfinite(p.w))
            read_error(path, pixel_name(i % width, i / width) + " is not finite");
    }
    return image;
}

}  // namespace smoketrace
