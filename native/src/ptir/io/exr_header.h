// OpenEXR headers checked before OpenEXR reads them: OpenEXR 3.1 allocates each
// attribute's declared size before reading it, so an 86-byte file declaring a
// 1.7 GB string attribute made the reader allocate it (found by tests/fuzz
// fuzz_image). Here every attribute of every part's header must fit in the file,
// and the types OpenEXR reads field by field (box2i, chlist, float, ...) must
// declare the size it reads: otherwise its reading falls out of step with the
// header and takes bytes inside a value for another attribute's size. The data
// window's sides must be 1..65536 pixels (memory_budget.h): OpenEXR allocates its
// line buffers for the declared width when it opens the file.
#pragma once

#include <cstdint>
#include <string>

namespace ptir::io {

// Throws Error(path, ...) when the file starts with OpenEXR's magic number and a
// header attribute (name, type, size) runs past the file's end or is malformed.
// Other files pass untouched. file_size: the file's size in bytes.
void check_exr_header(const std::string& path, uint64_t file_size);

}  // namespace ptir::io
